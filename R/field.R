#' Field measurements to calibrate against
#'
#' Holds the measurements at the library's control settings `x` and output
#' coordinates `t`: a complete table, a table with missing cells, or ragged
#' observations (different output coordinates at each x setting) in long
#' format.
#'
#' Missing measurements are `NA`. The likelihood uses the observed points
#' only (see [calibrate()]); [predict()][predict.griddy_fit] still predicts
#' every cell. Library x settings the field does not have, and library
#' output coordinates it does not have, are missing too.
#'
#' **Replicates.** Several experiments at one x setting are rows of `y` with
#' the same row of `x` (or, in long format, several rows of `y` at one
#' (x, t)). They are independent measurements of the same simulator output:
#' the likelihood sees each cell's (sd-weighted) mean, with relative sd
#' \eqn{1/\sqrt{\sum_r sd_r^{-2}}} (\eqn{1/\sqrt{n_{rep}}} without `sd`), the
#' correlation \eqn{R_g} holding between the means, and the replicates'
#' pure-error sum of squares \eqn{\sum_r (y_r - \bar y)^2 / sd_r^2}, with its
#' \eqn{n_{rep} - 1} degrees of freedom, added to every run's misfit: for
#' independent noise this is exactly the likelihood of every measurement,
#' and \eqn{n} counts every measurement. See [calibrate()]. The field keeps
#' the measurements as given.
#'
#' @param y The measurements: an `n_x x n_t` numeric matrix whose row `k` holds
#'   the measurements at the `k`-th x setting, or a numeric vector in the
#'   library's order (blocks of `n_t` values by x setting; `n_x * n_t`
#'   values when both `x` and `t` are given); `NA` marks a missing
#'   measurement. Or, in long format, a data.frame with one row per
#'   measurement: a column `t` (the output coordinate), a column `y` (the
#'   value), optionally a column `sd` (as the argument `sd`), and the x
#'   columns; cells not listed are missing, cells listed more than once are
#'   replicated (the j-th value of each cell goes to the j-th row of its
#'   setting). A data.frame with only one of the columns `t` and `y`, with a
#'   column spelled like `t`, `y` or `sd` in other case, or (in wide format)
#'   with columns of `x`, is refused: its columns would otherwise be read as
#'   measurements or settings. Without `x` and `t`, a matrix `y` must have
#'   the library's shape (its x settings by its outputs, checked by
#'   [calibrate()]), so that a transposed one is refused rather than read in
#'   the wrong order; a vector is in the library's order.
#' @param x A data.frame of the `n_x` control settings, one per row of `y`,
#'   with the library's (distinct) column names; `NULL` means "the library's
#'   settings, in its order". Rows may come in another order than the
#'   library's: [calibrate()] matches them by value. A setting repeated is a
#'   replicated experiment (see Replicates). In long format, `NULL` means the
#'   distinct settings of `y`, and a given `x` must have distinct rows.
#' @param t The `n_t` output coordinates; `NULL` means "the library's" (in
#'   long format, the distinct `t` of `y`, sorted). They must be among the
#'   library's coordinates (matched by value); the library's other
#'   coordinates are missing.
#' @param sd `NULL`, or known relative standard deviations of the
#'   measurements (like SEPIA's `Sigy`): the noise covariance becomes
#'   \eqn{\tau^{-1} S R S} with \eqn{S = diag(sd)}, so a measurement with
#'   twice the `sd` has twice the noise standard deviation. Positive numbers
#'   in the shape of `y` (`NA` allowed where `y` is missing), one per output
#'   coordinate (`n_t` values) or one per row of `y` (`n_x` values); in long
#'   format, one per row of `y`. Outputs in different units can be given
#'   their scales here (or see `noise_groups` in [calibrate()]).
#' @return An object of class `griddy_field`: a list with elements `y` (an
#'   `n_x x n_t` matrix, or a one-row matrix when `y` was a vector and neither
#'   `x` nor `t` fixes its shape; `NA` where missing), `x` and `t` as given
#'   (or as read from long format) and `sd` (`NULL` or a matrix the shape of
#'   `y`); and `one_setting = TRUE` for replicates in long format without x
#'   columns (every row at the library's single setting).
#' @seealso [sim_library()], [calibrate()]
#' @examples
#' field_data(matrix(rnorm(6), nrow = 2), x = data.frame(height = c(10, 20)))
#' field_data(c(1.2, NA, 0.5))
#' # ragged: two outputs at height 10, one at height 20
#' field_data(data.frame(height = c(10, 10, 20), t = c(0, 1, 1),
#'                       y = c(1.1, 0.7, 0.4)))
#' # replicates: three experiments at height 10, one at height 20
#' field_data(matrix(c(1.1, 1.0, 1.2, 0.4), ncol = 1),
#'            x = data.frame(height = c(10, 10, 10, 20)))
#' # in long format, two values of the cell (height 10, t 1)
#' field_data(data.frame(height = c(10, 10, 10, 20), t = c(0, 1, 1, 1),
#'                       y = c(1.1, 0.7, 0.8, 0.4)))
#' @export
field_data <- function(y, x = NULL, t = NULL, sd = NULL) {
  one_setting <- FALSE
  if (is.data.frame(y)) check_table_format(y, x)
  if (is_long_field(y)) {
    long <- long_field(y, x, t, sd)
    y <- long$y
    x <- long$x
    t <- long$t
    sd <- long$sd
    one_setting <- long$one_setting
  }
  if (is.data.frame(x)) {
    assert_column_names(x, "x")
    x <- as_numeric_columns(x, "x")
  }
  x <- as_settings(x, "x", distinct = FALSE)
  if (!is.null(t)) t <- assert_numeric_vector(t, "t")
  if (is.null(dim(y)) || length(dim(y)) == 1L) {
    y <- allow_missing(y, assert_numeric_vector, "y")
    y <- split_field_vector(y, if (!is.null(x)) nrow(x), if (!is.null(t)) length(t))
  } else {
    y <- allow_missing(y, as_numeric_matrix, "y", min_rows = 1L)
    if (ncol(y) < 1L) {
      griddy_abort("`y` must have at least 1 column; received ", nrow(y), " x 0.")
    }
  }
  if (all(is.na(y))) {
    griddy_abort("`y` holds no measurement: every value is NA.")
  }
  if (!is.null(x) && nrow(x) != nrow(y)) {
    griddy_abort("`y` must have one row per x setting: `x` has ", nrow(x),
                 " rows but `y` has ", nrow(y), ".")
  }
  if (!is.null(t)) as_coordinates(t, ncol(y), "t", "columns of `y`")
  dimnames(y) <- NULL
  field <- list(y = y, x = x, t = t, sd = field_sd_matrix(sd, y))
  # long format without x columns, with replicates: every row is at the
  # library's single setting
  if (one_setting) field$one_setting <- TRUE
  structure(field, class = "griddy_field")
}

# Validate `v` with `check` (a validator that refuses NA) with its NA cells
# standing in as 0, then put the NAs back: missing values are allowed, other
# non-finite ones are not.
allow_missing <- function(v, check, arg, ...) {
  if (!is.null(dim(v)) && !is.data.frame(v) && length(dim(v)) == 1L) v <- as.vector(v)
  if (is.logical(v) && all(is.na(v))) storage.mode(v) <- "double"
  miss <- if (is.data.frame(v)) is.na(as.matrix(v)) & !vapply(v, is.nan, logical(nrow(v)))
          else is.na(v) & !is.nan(v)
  if (is.data.frame(v)) {
    for (j in seq_along(v)) if (is.numeric(v[[j]])) v[[j]][miss[, j]] <- 0
  } else if (is.numeric(v)) {
    v[miss] <- 0
  }
  out <- check(v, arg, ...)
  out[if (is.matrix(out) && !is.matrix(miss)) matrix(miss, nrow(out)) else miss] <- NA
  out
}

# The relative standard deviations as a matrix the shape of `y` (n_x x n_t):
# given in that shape (or as a vector in y's order), one per t, or one per x
# setting.
field_sd_matrix <- function(sd, y) {
  if (is.null(sd)) return(NULL)
  n_x <- nrow(y)
  n_t <- ncol(y)
  if (is.matrix(sd) || is.data.frame(sd)) {
    sd <- allow_missing(sd, as_numeric_matrix, "sd")
    if (!identical(dim(sd), dim(y))) {
      griddy_abort("`sd` must have the shape of `y` (", n_x, " x ", n_t, "); received ",
                   nrow(sd), " x ", ncol(sd), ".", class = "shape")
    }
  } else {
    sd <- allow_missing(sd, assert_numeric_vector, "sd")
    n <- length(sd)
    if (n == n_x * n_t && (n_x == 1L || n_t == 1L || (n != n_x && n != n_t))) {
      sd <- matrix(sd, n_x, n_t, byrow = TRUE)
    } else if (n == n_t && n == n_x && n_x > 1L) {
      griddy_abort("`sd` has ", n, " values, one per x setting or one per output ",
                   "coordinate: the two are the same number here, so give `sd` as a ",
                   n_x, " x ", n_t, " matrix.", class = "shape")
    } else if (n == n_t) {
      sd <- matrix(sd, n_x, n_t, byrow = TRUE)
    } else if (n == n_x) {
      sd <- matrix(sd, n_x, n_t)
    } else {
      griddy_abort("`sd` must hold one value per measurement (", n_x * n_t, "), per output ",
                   "coordinate (", n_t, ") or per x setting (", n_x, "); received ", n, ".",
                   class = "shape")
    }
  }
  dimnames(sd) <- NULL
  bad <- which(!is.na(y) & (is.na(sd) | sd <= 0))
  if (length(bad) > 0L) {
    griddy_abort("`sd` must be a positive number wherever `y` is measured; it is ",
                 show_some(sd[bad]), " at cell(s) ", show_some(bad), ".")
  }
  sd
}

# Long format: a data.frame with columns `t` and `y`, the others x columns
# (and optionally `sd`).
is_long_field <- function(y) {
  is.data.frame(y) && all(c("t", "y") %in% names(y))
}

# A data.frame `y` is read in long format only when it has both columns `t`
# and `y`; a table with one of them (or `sd`), or with columns spelled like
# them, or with x's columns, was meant as long format or mixes settings with
# measurements: reading it as a wide matrix would turn those columns into
# measurements silently, so it is refused with the cause.
check_table_format <- function(y, x) {
  cols <- names(y)
  if (all(c("t", "y") %in% cols)) {
    near <- setdiff(cols[tolower(cols) %in% c("t", "y", "sd")], c("t", "y", "sd"))
    if (length(near) > 0L) {
      griddy_abort("`y` is in long format (columns `t` and `y`) and has column(s) ",
                   show_some(paste0("`", near, "`")), ", which would be read as x settings: ",
                   "name the relative sd column `sd` (lower case), or rename the column.")
    }
    return(invisible(y))
  }
  has <- intersect(c("t", "y", "sd"), cols)
  near <- setdiff(cols[tolower(cols) %in% c("t", "y", "sd")], has)
  if (length(has) > 0L || length(near) > 0L) {
    found <- c(has, near)[1]
    missing <- if (!"t" %in% cols) "t" else "y"
    others <- setdiff(cols, c("t", "y", "sd"))
    griddy_abort("`y` is a table with a column `", found, "` but no column `", missing, "`. ",
                 "In long format the output coordinates must be in a column named `t` and ",
                 "the measurements in a column named `y`",
                 if (length(others) > 0L) {
                   paste0(" (its other columns, ", show_some(paste0("`", others, "`")),
                          ", would be read as x settings)")
                 },
                 "; rename the columns. A table of measurements in wide format (one row ",
                 "per x setting, one column per output) must not have columns named `t`, ",
                 "`y` or `sd`: give it as a matrix.")
  }
  if (is.data.frame(x) && length(intersect(cols, names(x))) > 0L) {
    griddy_abort("`y` is a wide table of measurements, but its column(s) ",
                 show_some(intersect(cols, names(x))), " of `y` are also columns of `x`: ",
                 "they would be read as measurements. Give `y` without the x columns, or in ",
                 "long format (columns `t` and `y` with the x columns, see ?field_data).")
  }
  invisible(y)
}

# A long-format table as the wide matrix (settings x coordinates, NA where
# not measured), its settings, coordinates and sd.
long_field <- function(y, x, t, sd) {
  assert_column_names(y, "y")
  y <- as_numeric_columns(y, "y")
  if (!is.null(y$sd)) {
    if (!is.null(sd)) griddy_abort("Give `sd` either as a column of `y` or as an argument, not both.")
    sd <- y$sd
  }
  x_names <- setdiff(names(y), c("t", "y", "sd"))
  value <- allow_missing(y$y, assert_numeric_vector, "y$y")
  t_obs <- assert_numeric_vector(y$t, "y$t")
  if (!is.null(sd)) {
    sd <- allow_missing(sd, assert_numeric_vector, "sd")
    if (length(sd) != nrow(y)) {
      griddy_abort("In long format `sd` must have one value per row of `y` (", nrow(y),
                   "); received ", length(sd), ".", class = "shape")
    }
  }
  x_obs <- if (length(x_names) > 0L) {
    as.data.frame(as_numeric_matrix(y[x_names], "x columns of `y`"))
  }
  if (is.null(x)) {
    x <- if (!is.null(x_obs)) unique(x_obs)
    if (!is.null(x)) rownames(x) <- NULL
  } else if (is.data.frame(x)) {
    x <- as_settings(as_numeric_columns(x, "x"), "x")
  }
  if (is.null(t)) t <- sort(unique(t_obs))
  t <- assert_numeric_vector(t, "t")
  row <- if (is.null(x)) rep(1L, nrow(y)) else {
    if (is.null(x_obs) || !setequal(names(x), names(x_obs))) {
      griddy_abort("The x columns of `y` (", show_some(x_names), ") must be those of `x` (",
                   show_some(names(x)), ").")
    }
    match_setting_rows(x_obs[names(x)], x)
  }
  col <- vapply(t_obs, function(v) {
    hit <- which(same_values(t, v))
    if (length(hit) == 0L) NA_integer_ else hit[1]
  }, integer(1))
  if (anyNA(row) || anyNA(col)) {
    griddy_abort("Row(s) ", show_some(which(is.na(row) | is.na(col))), " of `y` are at ",
                 "settings or coordinates not in `x` or `t`.")
  }
  # Replicates: the j-th value of a cell (in the order of `y`) goes to the
  # j-th field row of its setting, so each setting has as many rows as its
  # most replicated cell. Which replicate shares a row with which does not
  # matter: the likelihood sees each cell's replicates only (field_layout()).
  n_set <- if (!is.null(x)) nrow(x) else 1L
  rep_no <- stats::ave(seq_along(row), (row - 1L) * length(t) + col, FUN = seq_along)
  depth <- vapply(seq_len(n_set), function(s) max(c(1L, rep_no[row == s])), integer(1))
  wide_row <- cumsum(c(0L, depth))[row] + rep_no
  cell <- cbind(wide_row, col)
  wide <- matrix(NA_real_, sum(depth), length(t))
  wide[cell] <- value
  if (!is.null(sd)) {
    sd_wide <- matrix(NA_real_, nrow(wide), ncol(wide))
    sd_wide[cell] <- sd
    sd <- sd_wide
  }
  if (!is.null(x)) {
    x <- x[rep(seq_len(n_set), depth), , drop = FALSE]
    rownames(x) <- NULL
  }
  list(y = wide, x = x, t = t, sd = sd, one_setting = is.null(x) && nrow(wide) > 1L)
}

# A vector of measurements as an n_x x n_t matrix (blocks of n_t by x
# setting); n_x and n_t are NULL when not given.
split_field_vector <- function(y, n_x, n_t) {
  n <- length(y)
  if (!is.null(n_x) && !is.null(n_t)) {
    if (n != n_x * n_t) {
      griddy_abort("`y` has ", n, " values but `x` has ", n_x, " settings and `t` ", n_t,
                   " coordinates: ", n_x, " x ", n_t, " = ", n_x * n_t, " expected.")
    }
  } else if (!is.null(n_t)) {
    if (n %% n_t != 0L) {
      griddy_abort("`y` has ", n, " values, which do not split into blocks of ", n_t,
                   " (the length of `t`).")
    }
  } else if (!is.null(n_x)) {
    if (n %% n_x != 0L) {
      griddy_abort("`y` has ", n, " values, which do not split into ", n_x,
                   " x settings of equal length.")
    }
    n_t <- n %/% n_x
  } else {
    n_t <- n
  }
  matrix(y, ncol = n_t, byrow = TRUE)
}

#' @export
print.griddy_field <- function(x, ...) {
  n_miss <- sum(is.na(x$y))
  n <- length(x$y) - n_miss
  rep <- field_replication(x)
  head <- if (rep$replicated == 0L && rep$settings == nrow(x$y)) {
    paste0(n, " measurement(s): ", nrow(x$y), " x setting(s) x ", ncol(x$y), " output(s)",
           if (n_miss > 0L) paste0(", ", n_miss, " missing"))
  } else {
    paste0(n, " measurement(s) at ", rep$settings, " x setting(s), ", rep$replicated,
           " replicated (", nrow(x$y), " experiments) x ", ncol(x$y), " output(s)")
  }
  cli::cat_line("<griddy_field> ", head, if (!is.null(x$sd)) ", with relative sd")
  cli::cat_line("  range ", format(min(x$y, na.rm = TRUE), digits = 4), " to ",
                format(max(x$y, na.rm = TRUE), digits = 4))
  invisible(x)
}

# The distinct x setting of each field row (experiment): `setting`, indices
# into the field's distinct settings; how many there are (`settings`); and
# how many of them have some output measured more than once (`replicated`).
field_replication <- function(field) {
  setting <- if (isTRUE(field$one_setting)) {
    rep(1L, nrow(field$y))
  } else if (is.null(field$x)) {
    seq_len(nrow(field$y))
  } else {
    distinct <- unique(field$x)
    match_setting_rows(field$x, distinct)
  }
  count <- rowsum(1L * !is.na(field$y), setting, reorder = TRUE)
  list(setting = setting, settings = nrow(count),
       replicated = sum(apply(count > 1L, 1, any)))
}

# The field measurements as one vector in the library's order (blocks by x
# setting), NA where not measured, after checking that their x and t are
# among the library's; for methods that take one measurement per cell (not
# replicates). The caller has checked `library` (check_library()).
field_vector <- function(library, field) {
  layout <- field_layout(library, field)
  if (any(layout$n_rep > 1L)) {
    griddy_abort("This method takes one field measurement per x setting and output; ",
                 "`field` has replicated measurements (", sum(layout$n_rep), " at ",
                 sum(layout$n_rep > 0L), " cells). calibrate() takes them.",
                 class = "unsupported")
  }
  layout$y
}

# What the likelihood needs from the field, each a vector in the library's
# order (field settings and coordinates matched to the library's by value,
# the library's others missing):
#   y       each cell's measurement, or the sd-weighted mean of its
#           replicates (NA where not measured);
#   sd      NULL, or the relative sd of one measurement (a replicated cell's
#           sqrt(n_rep / sum 1/sd_r^2), its replicates' sd when they share
#           it; an unmeasured cell keeps the sd the field gives it): what
#           predict() adds noise with;
#   sd_mean NULL (no sd, no replicates), or the relative sd of y:
#           1 / sqrt(sum 1/sd_r^2), 1 / sqrt(n_rep) without sd;
#   n_rep   the number of measurements in each cell (0 where missing);
#   pure_ss the pure-error sum of squares of each cell,
#           sum_r (y_r - ybar)^2 / sd_r^2, with n_rep - 1 degrees of freedom;
#   log_sd_excess  sum_r log sd_r^2 - log sd_mean^2, summed over the cells.
# For independent noise, sum_r (y_r - g)^2 / sd_r^2 = pure_ss +
# (ybar - g)^2 / sd_mean^2 and the replicates' density is that of the mean
# times exp(-tau pure_ss / 2) tau^((n_rep - 1)/2) (2 pi)^(-(n_rep - 1)/2)
# exp(-log_sd_excess / 2): this is where replicates reduce to cells (and
# noise_pattern() hands pure_ss and its degrees of freedom to the noise
# groups).
field_layout <- function(library, field) {
  cells <- field_cells(library, field)
  cell_summary(cells$cell, cells$value, cells$sd, lib_n_x(library) * lib_n_t(library))
}

# The one mapping from field data to library cells, for calibrate() and
# posterior_exact() (through field_layout()) and for the stream alike (so
# both check the same things and read the same cells): for each entry of
# the field's measurements, its library output `cell` (blocks of n_t by x
# setting; settings and coordinates matched by value, see match_settings()),
# its `value` (NA where not measured) and its relative `sd` (NULL without).
field_cells <- function(library, field) {
  if (!inherits(field, "griddy_field")) {
    griddy_abort("`field` must be a griddy_field (see ?field_data); received ",
                 class(field)[1], ".")
  }
  n_x <- lib_n_x(library)
  n_t <- lib_n_t(library)
  y <- field$y
  if (is.null(field$x) && is.null(field$t) && !isTRUE(field$one_setting)) {
    check_field_shape(y, n_x, n_t)
    # rows are x settings in the library's order: the vector of t(y)
    out <- list(cell = seq_len(n_x * n_t), value = as.vector(t(y)),
                sd = if (!is.null(field$sd)) as.vector(t(field$sd)))
  } else {
    cols <- field_columns(field, ncol(y), lib_t(library))
    rows <- field_rows(field, nrow(y), n_x, lib_x(library))
    out <- list(cell = as.vector(outer((rows - 1L) * n_t, cols, "+")), value = as.vector(y),
                sd = if (!is.null(field$sd)) as.vector(field$sd))
  }
  if (all(is.na(out$value))) {
    griddy_abort("`field` holds no measurement at the library's settings.")
  }
  out
}

# A field without x and t is the library's outputs in order: a vector, or a
# matrix of the library's shape (a transposed one would be read in the
# wrong order).
check_field_shape <- function(y, n_x, n_t) {
  if (nrow(y) > 1L && !all(dim(y) == c(n_x, n_t))) {
    griddy_abort("`field` is ", nrow(y), " x ", ncol(y), " (rows x columns of `y`) but ",
                 "the library has ", n_x, " x settings x ", n_t, " outputs: `y` must be ",
                 "an ", n_x, " x ", n_t, " matrix, one row per x setting in the library's ",
                 "order",
                 if (nrow(y) == n_t && ncol(y) == n_x) {
                   paste0("; it looks transposed (one row per output): give t(y)")
                 } else {
                   "; or give `x` and `t` to say which row and column is which"
                 }, ".", class = "shape")
  }
  if (length(y) != n_x * n_t) {
    griddy_abort("`field` has ", length(y), " measurements but the library has ",
                 n_x, " x setting(s) x ", n_t, " output(s) = ", n_x * n_t, ".")
  }
}

# The library output coordinate of each column of the field's y.
field_columns <- function(field, n_col, t_lib) {
  if (!is.null(field$t)) return(match_coordinates(field$t, t_lib))
  if (n_col != length(t_lib)) {
    griddy_abort("`field` has ", n_col, " output(s) per x setting but the library has ",
                 length(t_lib), ".")
  }
  seq_len(n_col)
}

# The library x setting of each row of the field's y.
field_rows <- function(field, n_row, n_x, x_lib) {
  if (isTRUE(field$one_setting)) {
    if (n_x != 1L) {
      griddy_abort("`field` has replicated measurements at one setting and no x columns, ",
                   "but the library has ", n_x, " x settings: give the x columns.")
    }
    return(rep(1L, n_row))
  }
  if (is.null(field$x)) {
    if (n_row != n_x) {
      griddy_abort("`field` has ", n_row, " x setting(s) but the library has ", n_x, ".")
    }
    return(seq_len(n_x))
  }
  match_settings(field$x, x_lib)
}

# field_layout() from the measurements `value` (NA where missing), their
# relative sd (NULL, or one per value) and the library output `cell` each is
# at, over `n_cells` library outputs. A cell measured once keeps its value
# and sd exactly.
cell_summary <- function(cell, value, sd, n_cells) {
  keep <- !is.na(value)
  n_rep <- tabulate(cell[keep], n_cells)
  sd_one <- if (!is.null(sd)) one_measurement_sd(cell, sd, keep | n_rep[cell] == 0L, n_cells)
  cell <- cell[keep]
  value <- value[keep]
  s <- if (is.null(sd)) rep(1, length(value)) else sd[keep]
  y <- rep(NA_real_, n_cells)
  if (all(n_rep <= 1L)) {
    y[cell] <- value
    return(list(y = y, sd = sd_one, sd_mean = sd_one, n_rep = n_rep,
                pure_ss = numeric(n_cells), log_sd_excess = 0))
  }
  w <- 1 / s^2
  measured <- sort(unique(cell))
  W <- numeric(n_cells)
  W[measured] <- rowsum(w, cell)[, 1]
  y[measured] <- rowsum(w * value, cell)[, 1]
  y <- y / W
  single <- n_rep[cell] == 1L
  y[cell[single]] <- value[single]
  pure_ss <- numeric(n_cells)
  pure_ss[measured] <- rowsum(w * (value - y[cell])^2, cell)[, 1]
  pure_ss[cell[single]] <- 0
  sd_mean <- rep(NA_real_, n_cells)
  sd_mean[measured] <- 1 / sqrt(W[measured])
  sd_mean[cell[single]] <- s[single]
  list(y = y, sd = sd_one, sd_mean = sd_mean, n_rep = n_rep, pure_ss = pure_ss,
       log_sd_excess = sum(log(s^2)) - sum(log(sd_mean[measured]^2)))
}

# The relative sd of one measurement in each cell from the sd of the entries
# `use` (a measured cell's measurements; any entry of an unmeasured cell, so
# predict() has its sd): sqrt(m / sum 1/sd^2) over its m entries, the sd
# itself for one entry, NA for none.
one_measurement_sd <- function(cell, sd, use, n_cells) {
  use <- use & !is.na(sd)
  out <- rep(NA_real_, n_cells)
  if (!any(use)) return(out)
  m <- tabulate(cell[use], n_cells)
  has <- sort(unique(cell[use]))
  out[has] <- sqrt(m[has] / rowsum(1 / sd[use]^2, cell[use])[, 1])
  one <- use & m[cell] == 1L
  out[cell[one]] <- sd[one]
  out
}

same_values <- function(a, b) abs(a - b) <= 1e-8 * pmax(1, abs(a), abs(b))

# The library column of each field coordinate (matched by value, the nearest
# when several are within rounding); an error names those the library does
# not have.
match_coordinates <- function(t_field, t_lib) {
  hit <- vapply(t_field, function(v) {
    same <- which(same_values(t_lib, v))
    if (length(same) == 0L) NA_integer_ else same[which.min(abs(t_lib[same] - v))]
  }, integer(1))
  if (anyNA(hit)) {
    bad <- which(is.na(hit))
    griddy_abort("`field$t` does not match the library's t: field coordinate(s) ",
                 show_some(format(t_field[bad])), " (position(s) ", show_some(bad),
                 ") are not among the library's ", length(t_lib), " coordinates from ",
                 format(min(t_lib)), " to ", format(max(t_lib)), ".")
  }
  hit
}

# For each row of `rows`, the first row of `table` (same columns, in the same
# order) holding the same values to within same_values(); NA where none does.
match_setting_rows <- function(rows, table) {
  vapply(seq_len(nrow(rows)), function(k) {
    same <- which(Reduce(`&`, Map(same_values, table, rows[k, ])))
    if (length(same) == 0L) NA_integer_ else same[1]
  }, integer(1))
}

# For each row of the field's x, the library setting (row) it is at; an
# error names field settings the library does not have. Library settings
# the field lacks are missing data.
match_settings <- function(x_field, x_lib) {
  if (is.null(x_lib)) {
    if (nrow(x_field) != 1L) {
      griddy_abort("`field` has ", nrow(x_field), " x settings but the library has one.")
    }
    return(1L)
  }
  if (!setequal(names(x_field), names(x_lib))) {
    griddy_abort("`field$x` has column(s) ", show_some(names(x_field)),
                 " but the library's x has ", show_some(names(x_lib)), ".")
  }
  hit <- match_setting_rows(x_field[names(x_lib)], x_lib)
  if (anyNA(hit)) {
    griddy_abort("`field` has x setting(s) at row(s) ", show_some(which(is.na(hit))),
                 " that the library does not have.")
  }
  hit
}
