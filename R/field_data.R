#' Field measurements to calibrate against
#'
#' Holds the measurements at the library's control settings `x` and output
#' coordinates `t`.
#'
#' @param y The measurements: an `n_x x n_t` numeric matrix whose row `k` holds
#'   the measurements at the `k`-th x setting, or a numeric vector in the
#'   library's order (blocks of `n_t` values by x setting; `n_x * n_t`
#'   values when both `x` and `t` are given).
#' @param x A data.frame of the `n_x` control settings, with the library's
#'   (distinct) column names; `NULL` means "the library's settings, in its order". Rows
#'   may come in another order than the library's: [calibrate()] matches them
#'   by value.
#' @param t The `n_t` output coordinates; `NULL` means "the library's".
#' @return An object of class `griddy_field`: a list with elements `y` (an
#'   `n_x x n_t` matrix, or a one-row matrix when `y` was a vector and neither
#'   `x` nor `t` fixes its shape), `x` and `t` as given.
#' @seealso [sim_library()], [calibrate()]
#' @examples
#' field_data(matrix(rnorm(6), nrow = 2), x = data.frame(height = c(10, 20)))
#' field_data(c(1.2, 0.8, 0.5))
#' @export
field_data <- function(y, x = NULL, t = NULL) {
  if (is.data.frame(x)) {
    assert_column_names(x, "x")
    x <- as_numeric_columns(x, "x")
  }
  x <- as_settings(x, "x")
  if (!is.null(t)) t <- assert_numeric_vector(t, "t")
  if (is.null(dim(y)) || length(dim(y)) == 1L) {
    y <- assert_numeric_vector(y, "y")
    y <- split_field_vector(y, if (!is.null(x)) nrow(x), if (!is.null(t)) length(t))
  } else {
    y <- as_numeric_matrix(y, "y", min_rows = 1L)
    if (ncol(y) < 1L) {
      griddy_abort("`y` must have at least 1 column; received ", nrow(y), " x 0.")
    }
  }
  if (!is.null(x) && nrow(x) != nrow(y)) {
    griddy_abort("`y` must have one row per x setting: `x` has ", nrow(x),
                 " rows but `y` has ", nrow(y), ".")
  }
  if (!is.null(t)) as_coordinates(t, ncol(y), "t", "columns of `y`")
  dimnames(y) <- NULL
  structure(list(y = y, x = x, t = t), class = "griddy_field")
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
  cli::cat_line("<griddy_field> ", length(x$y), " measurement(s): ",
                nrow(x$y), " x setting(s) x ", ncol(x$y), " output(s)")
  cli::cat_line("  range ", format(min(x$y), digits = 4), " to ",
                format(max(x$y), digits = 4))
  invisible(x)
}

# The field measurements as one vector in the library's order (blocks by x
# setting), after checking that their x and t are the library's.
# The caller has checked `library` (check_library()).
field_vector <- function(library, field) {
  if (!inherits(field, "griddy_field")) {
    griddy_abort("`field` must be a griddy_field (see ?field_data); received ",
                 class(field)[1], ".")
  }
  n_x <- lib_n_x(library)
  n_t <- lib_n_t(library)
  y <- field$y
  if (!is.null(field$t)) match_coordinates(field$t, library$t)
  if (is.null(field$x)) {
    if (length(y) != n_x * n_t) {
      griddy_abort("`field` has ", length(y), " measurements but the library has ",
                   n_x, " x setting(s) x ", n_t, " output(s) = ", n_x * n_t, ".")
    }
    return(as.vector(t(y)))
  }
  order <- match_settings(field$x, library$x)
  if (ncol(y) != n_t) {
    griddy_abort("`field` has ", ncol(y), " output(s) per x setting but the library has ",
                 n_t, ".")
  }
  as.vector(t(y[order, , drop = FALSE]))
}

same_values <- function(a, b) abs(a - b) <= 1e-8 * pmax(1, abs(a), abs(b))

match_coordinates <- function(t_field, t_lib) {
  if (length(t_field) != length(t_lib) || !all(same_values(t_field, t_lib))) {
    griddy_abort("`field$t` does not match the library's t: the field has ",
                 length(t_field), " coordinate(s) from ", format(min(t_field)), " to ",
                 format(max(t_field)), ", the library ", length(t_lib), " from ",
                 format(min(t_lib)), " to ", format(max(t_lib)), ".")
  }
}

# For each row of `rows`, the first row of `table` (same columns, in the same
# order) holding the same values to within same_values(); NA where none does.
match_setting_rows <- function(rows, table) {
  vapply(seq_len(nrow(rows)), function(k) {
    same <- which(Reduce(`&`, Map(same_values, table, rows[k, ])))
    if (length(same) == 0L) NA_integer_ else same[1]
  }, integer(1))
}

# For each library setting, the row of the field's x holding it.
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
  hit <- match_setting_rows(x_lib, x_field[names(x_lib)])
  if (anyNA(hit)) {
    griddy_abort("`field` has no measurements at library x setting(s) ",
                 show_some(which(is.na(hit))), ".")
  }
  extra <- setdiff(seq_len(nrow(x_field)), hit)
  if (length(extra) > 0L) {
    griddy_abort("`field` has x setting(s) at row(s) ", show_some(extra),
                 " that the library does not have.")
  }
  hit
}
