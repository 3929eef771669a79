#' Add measurements to a streaming calibration
#'
#' Adds one measurement, a batch of them, or a [field_data()] to a
#' [griddy_stream()], all of them in one pass over the library's runs (see
#' [griddy_stream()] for the update and for what is not incremental).
#'
#' @param object A [griddy_stream()].
#' @param y The measurement(s): a numeric vector (no `NA`), or a
#'   [field_data()] (then `x` and `t` must be `NULL`; its measurements are
#'   taken setting by setting, in increasing t).
#' @param x The x setting of each measurement: a data.frame with the
#'   library's x columns and one row per value of `y` (or one row for all of
#'   them); `NULL` when the library has a single setting.
#' @param t The output coordinate of each measurement (among the library's
#'   `t`), one per value of `y`.
#' @param ... Ignored.
#' @return The stream, updated in place (a stream is a reference object:
#'   see [griddy_stream()]).
#' @seealso [griddy_stream()]
#' @examples
#' ex <- griddy_example()
#' s <- griddy_stream(ex$library, rho_t = c(0, 0.5))
#' x1 <- ex$field$x[1, , drop = FALSE]
#' s <- update(s, y = ex$field$y[1, 1], x = x1, t = ex$library$t[1])        # one
#' s <- update(s, y = ex$field$y[1, 2:4], x = x1, t = ex$library$t[2:4])    # a batch
#' nobs(s)
#' @export
update.griddy_stream <- function(object, y, x = NULL, t = NULL, ...) {
  state <- object$state
  cells <- stream_cells(state$library, y, x, t)
  # the terms go in in one pass at the end, also when a measurement is
  # refused part-way (those before it are counted, so their terms must be in)
  on.exit(stream_flush(state), add = TRUE)
  for (m in seq_along(cells$column)) stream_add(state, cells$column[m], cells$y[m])
  object
}

# The library output column and value of each measurement given to
# update(): a field_data (stream_field_cells()) or vectors y, x, t.
stream_cells <- function(library, y, x = NULL, t = NULL) {
  if (!inherits(y, "griddy_field")) return(measurement_cells(library, y, x, t))
  if (!is.null(x) || !is.null(t)) {
    griddy_abort("With a field_data `y`, `x` and `t` must be NULL (the field has them).")
  }
  stream_field_cells(library, y)
}

# The library output column (blocks of n_t by x setting) and value of each
# measurement given as vectors y, x, t.
measurement_cells <- function(library, y, x, t) {
  y <- assert_numeric_vector(y, "y")
  if (is.null(t) || length(t) != length(y)) {
    griddy_abort("`t` must give the output coordinate of each measurement (", length(y),
                 "); received ", length(t), ".", class = "shape")
  }
  j <- match_coordinates(assert_numeric_vector(t, "t"), lib_t(library))
  k <- if (is.null(x)) {
    if (lib_n_x(library) > 1L) {
      griddy_abort("`x` must give the x setting of the measurements: the library has ",
                   lib_n_x(library), " settings.", class = "shape")
    }
    rep(1L, length(y))
  } else {
    if (!is.data.frame(x) || !nrow(x) %in% c(1L, length(y))) {
      griddy_abort("`x` must be a data.frame with one row per measurement (", length(y),
                   ") or one row; received ", class(x)[1],
                   if (is.data.frame(x)) paste0(" with ", nrow(x), " rows"), ".",
                   class = "shape")
    }
    rep_len(stream_settings(as_numeric_columns(x, "x"), lib_x(library)), length(y))
  }
  list(column = (k - 1L) * lib_n_t(library) + j, y = y)
}

# The library setting of each row of `x` (match_settings()'s answer), read
# column by column rather than row by row through `[.data.frame`: a
# measurement arriving with its setting is matched in microseconds, so that
# an update costs its pass over the runs, not its lookup. An unknown or
# misnamed setting goes to match_settings() for its error.
stream_settings <- function(x, x_lib) {
  if (is.null(x_lib) || !setequal(names(x), names(x_lib))) return(match_settings(x, x_lib))
  hit <- vapply(seq_len(nrow(x)), function(k) {
    same <- TRUE
    for (nm in names(x_lib)) same <- same & same_values(x_lib[[nm]], x[[nm]][k])
    which(same)[1]
  }, integer(1))
  if (anyNA(hit)) return(match_settings(x, x_lib))
  hit
}

# The measurements of a field_data as columns and values, setting by setting
# in increasing t (replicates one after the other, in the field's order):
# the cells of field_cells(), the mapping calibrate() uses.
stream_field_cells <- function(library, field) {
  if (inherits(field, "griddy_field") && !is.null(field$sd)) {
    griddy_abort("A stream takes no relative `sd` of measurements.", class = "unsupported")
  }
  cells <- field_cells(library, field)
  keep <- which(!is.na(cells$value))
  o <- keep[order(cells$cell[keep])]  # order() keeps ties in place
  list(column = cells$cell[o], y = cells$value[o])
}

# Add one measurement (library output `column`, value `y`) to the stream's
# state, in place.
stream_add <- function(state, column, y) {
  n_t <- lib_n_t(state$library)
  setting <- (column - 1L) %/% n_t + 1L
  k <- state$group[column]
  prev <- state$last_column[setting, k]
  if (state$markov && !is.na(prev) && column <= prev) {
    if (state$measured[column]) {
      griddy_abort("Output ", column, " (x setting ", setting, ", t = ",
                   format(lib_t(state$library)[(column - 1L) %% n_t + 1L]), ") was measured ",
                   "already: under an AR(1) correlation over t a replicate has no ",
                   "incremental update. Average the replicates, or use calibrate().",
                   class = "unsupported")
    }
    stream_record(state, column, y)
    rlang::inform(paste0("A measurement arrived at an earlier t than the last one at its ",
                         "x setting: the AR(1) innovations need t order, so the stream ",
                         "recomputes its forms from all ", length(state$data$y),
                         " measurements."),
                  class = c("griddy_message_stream_replay", "griddy_message"))
    return(stream_replay(state))
  }
  stream_accumulate(state, column, y)
  stream_record(state, column, y)
}

# The forms, count and log-determinant updated with one measurement.
stream_accumulate <- function(state, column, y) {
  setting <- (column - 1L) %/% lib_n_t(state$library) + 1L
  k <- state$group[column]
  G <- length(state$rho_t)
  prev <- state$last_column[setting, k]
  if (state$markov && !is.na(prev)) {
    phi <- state$rho_t^(state$s_unit[column - (setting - 1L) * lib_n_t(state$library)] -
                          state$s_unit[prev - (setting - 1L) * lib_n_t(state$library)])
    if (any(phi >= 1)) {
      griddy_abort("`rho_t` value(s) give neighbouring measurements a correlation that ",
                   "rounds to 1; use values further from 1.", class = "numeric")
    }
    one_minus <- 1 - phi^2
    check_term_bound(state, y, column, prev, state$last_y[setting, k], phi, 1 / one_minus)
    add_column(state, column, y, prev, state$last_y[setting, k], phi, 1 / one_minus, k, G)
    state$logdet <- state$logdet + log(one_minus)
  } else {
    check_term_bound(state, y, column, NA_integer_, 0, 0, 1)
    add_column(state, column, y, 0L, 0, numeric(G), rep(1, G), k, G)
  }
  state$n[k] <- state$n[k] + 1L
  state$last_column[setting, k] <- column
  state$last_y[setting, k] <- y
  state$cache <- NULL
  invisible(state)
}

# The forms are changed in place, so a term that would overflow them is
# refused before any is changed (the C++ check comes after the change, and
# the stream would keep infinite forms): a bound on the new term,
# (|y| + max |output| + phi (|y_prev| + max |previous output|))^2 scale,
# added to the bound on every form so far.
check_term_bound <- function(state, y, column, prev, y_prev, phi, scale) {
  r <- abs(y) + state$out_absmax[column]
  q <- if (is.na(prev)) 0 else max(abs(phi)) * (abs(y_prev) + state$out_absmax[prev])
  bound <- state$C_bound + (r + q)^2 * max(scale)
  if (!is.finite(bound)) abort_overflow(y)
  state$C_bound <- bound
  invisible(state)
}

# A measurement's term, kept until stream_flush() adds the update's terms
# in one pass over the runs (what the terms need is known without C).
add_column <- function(state, column, y, prev, y_prev, phi, scale, k, G) {
  state$pending[[length(state$pending) + 1L]] <-
    list(column = column - 1L, y = y, prev = prev - 1L, y_prev = y_prev, phi = phi,
         scale = scale, offset = (k - 1L) * G)
  invisible(state)
}

# The pending terms added to the forms, in place, in arrival order (each
# form gets the sums one measurement at a time would give it).
stream_flush <- function(state) {
  terms <- state$pending
  if (length(terms) == 0L) return(invisible(state))
  state$pending <- list()
  field <- function(name) vapply(terms, `[[`, numeric(1), name)
  y <- field("y")
  withCallingHandlers(
    stream_add_cpp(state$C, state$outputs, as.integer(field("column")), y,
                   as.integer(field("prev")), field("y_prev"),
                   matrix(unlist(lapply(terms, `[[`, "phi")), ncol = length(terms)),
                   matrix(unlist(lapply(terms, `[[`, "scale")), ncol = length(terms)),
                   as.integer(field("offset"))),
    error = function(e) {
      if (grepl("not finite", conditionMessage(e), fixed = TRUE)) abort_overflow(y)
    })
  invisible(state)
}

# The data so far, in arrival order (what stream_data() reports).
stream_record <- function(state, column, y) {
  state$data$column <- c(state$data$column, column)
  state$data$y <- c(state$data$y, y)
  state$measured[column] <- TRUE
  invisible(state)
}

# Recompute the statistics from all the data, in library order (setting by
# setting, increasing t), which the AR(1) innovations need.
stream_replay <- function(state) {
  data <- state$data
  stream_reset(state)
  o <- order(data$column)
  for (m in o) stream_accumulate(state, data$column[m], data$y[m])
  state$data <- data
  state$measured[data$column] <- TRUE
  invisible(state)
}
