#' A library of simulation runs
#'
#' Collects the runs of a simulator over a design of its unknown parameters
#' \eqn{\theta}: one row per run, holding the run's outputs at every control
#' setting `x` and output coordinate `t`, in the layout of the thesis's
#' Appendix A.1.
#'
#' Row `i` of `y` holds run `i`'s outputs in blocks by `x` setting: block `k`
#' (columns `(k - 1) * n_t + 1` to `k * n_t`) holds the `n_t` outputs at the
#' `k`-th row of `x`, in the order of `t`. The runs may form a full-factorial
#' grid, a Latin hypercube or any other design; each row is one point of the
#' discrete parameter space the sampler moves on.
#'
#' @param theta A data.frame, or a numeric matrix with column names, of the
#'   parameter values: one row per run (`N x p`), at least two runs.
#' @param y A numeric matrix `N x (n_x * n_t)` of the runs' outputs.
#' @param x A data.frame (or numeric vector or named matrix) of the `n_x`
#'   control settings, one row each; `NULL` for a single setting. Its
#'   columns may not be named `setting`, `t`, `observed`, `residual`, `mean`,
#'   `sd`, `lower`, `upper`, `pred_lower` or `pred_upper`: [predict()] and
#'   [discrepancy_posterior()] put columns of those names beside them.
#' @param t The `n_t` output coordinates (time, or a location index), strictly
#'   increasing; `NULL` gives `1:n_t`.
#' @return An object of class `sim_library`: a list with elements `theta` (a
#'   data.frame), `y` (a matrix), `x` (a data.frame or `NULL`) and `t` (a
#'   numeric vector).
#' @seealso [field_data()], [read_calibration_inputs()], [calibrate()]
#' @examples
#' theta <- expand.grid(k = seq(1, 3, by = 0.5), c = c(0.1, 0.2, 0.3))
#' t <- seq(0, 2, length.out = 20)
#' y <- t(apply(theta, 1, function(p) exp(-p[["c"]] * t) * cos(p[["k"]] * t)))
#' lib <- sim_library(theta, y, t = t)
#' lib
#' @export
sim_library <- function(theta, y, x = NULL, t = NULL) {
  theta_mat <- as_theta_matrix(theta)
  n_runs <- nrow(theta_mat)
  assert_library_size(n_runs)
  y <- as_numeric_matrix(y, "y")
  if (nrow(y) != n_runs) {
    griddy_abort("`y` must have one row per run: `theta` has ", n_runs,
                 " rows but `y` has ", nrow(y), ".")
  }
  x <- as_settings(x, "x")
  n_x <- n_settings(x)
  if (ncol(y) %% n_x != 0L) {
    griddy_abort("`y` has ", ncol(y), " columns, which is not a multiple of the ",
                 n_x, " x settings (rows of `x`).")
  }
  t <- as_coordinates(t, ncol(y) %/% n_x, "t", "`y` columns per x setting")
  assert_distinct_runs(theta_mat)
  warn_constant_columns(theta_mat)
  structure(
    list(theta = as.data.frame(theta_mat), y = y, x = x, t = t),
    class = "sim_library"
  )
}

#' @export
print.sim_library <- function(x, ...) {
  n_x <- lib_n_x(x)
  ranges <- vapply(x$theta, function(v) {
    paste0(format(min(v), digits = 4), " to ", format(max(v), digits = 4))
  }, "")
  cli::cat_line("<sim_library> ", nrow(x$y), " runs of ", ncol(x$theta),
                " parameter(s)")
  cli::cat_line("  theta: ", paste0(names(ranges), " [", ranges, "]", collapse = ", "))
  cli::cat_line("  x:     ", if (is.null(x$x)) "one setting" else
    paste0(n_x, " setting(s) of ", paste(names(x$x), collapse = ", ")))
  cli::cat_line("  t:     ", length(x$t), " output(s), ",
                format(min(x$t), digits = 4), " to ", format(max(x$t), digits = 4))
  cli::cat_line("  y:     ", nrow(x$y), " x ", ncol(x$y), " (runs x outputs, ",
                format(utils::object.size(x$y), units = "auto"), ")")
  invisible(x)
}

# ---- the library interface, in memory (see library.R) -----------

#' @exportS3Method
lib_outputs.sim_library <- function(library, rows = NULL) {
  if (is.null(rows)) return(library$y)
  library$y[lib_check_rows(library, rows), , drop = FALSE]
}

# quad_forms_cpp() checks that every misfit is finite, which the outputs must
# be for that, in the pass it makes anyway; when it fails because the library
# was edited to hold NA or Inf, the cells are named here (any other failure,
# an overflow, goes on to misfit_table()).
#' @exportS3Method
lib_quad_forms.sim_library <- function(library, y_field, setup) {
  withCallingHandlers(plain_quad_forms(library$y, y_field, setup),
                      error = function(e) {
    tryCatch(assert_finite(library$y, "library$y"), griddy_error = function(e2) {
      griddy_abort("The sim_library has been edited: ", conditionMessage(e2),
                   " Rebuild it with sim_library().", class = "shape")
    })
  })
}

#' @exportS3Method
lib_check_integrity.sim_library <- function(library) {
  y <- library$y
  theta <- library$theta
  if (!is.matrix(y) || !is.double(y) || !is.data.frame(theta) ||
      !all(vapply(theta, is.double, logical(1)))) {
    griddy_abort("The sim_library has been edited: `y` must be a double matrix and ",
                 "`theta` a data.frame of double columns; rebuild it with sim_library().",
                 class = "shape")
  }
  if (nrow(y) != nrow(theta) || ncol(y) != lib_n_out(library)) {
    griddy_abort("The sim_library has been edited: `y` is ", nrow(y), " x ", ncol(y),
                 " but `theta` has ", nrow(theta), " rows and x, t give ", lib_n_x(library),
                 " x ", lib_n_t(library), " = ", lib_n_out(library), " outputs per run; ",
                 "rebuild it with sim_library().", class = "shape")
  }
  check_library_parts(library, nrow(y), ncol(y), "sim_library",
                      fix = "Rebuild it with sim_library().")
  # the outputs' finiteness is checked where they are read (lib_quad_forms)
  invisible(library)
}

as_theta_matrix <- function(theta) {
  if (!is.data.frame(theta) && !is.matrix(theta)) {
    griddy_abort("`theta` must be a data.frame or a numeric matrix with column names; ",
                 "received ", class(theta)[1], ".")
  }
  if (is.null(colnames(theta)) || any(colnames(theta) == "")) {
    griddy_abort("`theta` must have a name for every column.")
  }
  if (anyDuplicated(colnames(theta))) {
    griddy_abort("`theta` has duplicated column names: ",
                 show_some(colnames(theta)[duplicated(colnames(theta))]), ".")
  }
  if (ncol(theta) < 1L) {
    griddy_abort("`theta` must have at least one parameter column.")
  }
  as_numeric_matrix(theta, "theta")
}

# A library needs at least 2 runs (a posterior over one run is that run);
# `where` says where the runs were counted.
assert_library_size <- function(n_runs, where = "`theta`") {
  if (n_runs >= 2L) return(invisible(n_runs))
  griddy_abort(where, " holds ", n_runs, " run", if (n_runs != 1L) "s", ": a library needs ",
               "at least 2 runs (rows of theta, each with its outputs).",
               class = "library_size")
}

# Control settings: a data.frame with named numeric columns and distinct rows
# (`distinct = FALSE`: rows may repeat, as the field's replicated experiments
# do).
as_settings <- function(x, arg, distinct = TRUE) {
  if (is.null(x)) {
    return(NULL)
  }
  if (is.numeric(x) && is.null(dim(x))) {
    x <- data.frame(x = x)
  }
  if (is.matrix(x)) {
    if (is.null(colnames(x))) colnames(x) <- paste0("x", seq_len(ncol(x)))
    x <- as.data.frame(x)
  }
  if (!is.data.frame(x) || ncol(x) < 1L || nrow(x) < 1L) {
    griddy_abort("`", arg, "` must be a data.frame of control settings, one row each; ",
                 "received ", class(x)[1], ".")
  }
  assert_unreserved_columns(names(x), arg)
  # plain doubles: integer and integer64 columns are read as their numbers
  x <- as.data.frame(as_numeric_matrix(x, arg))
  dup <- if (distinct) which(duplicated(x)) else integer(0)
  if (length(dup) > 0L) {
    griddy_abort("`", arg, "` has duplicated settings at row(s) ", show_some(dup), ".")
  }
  rownames(x) <- NULL
  x
}

# The columns that predict(), discrepancy_posterior() and their plots put
# beside the x columns in one table (setting_cells()): an x column of one of
# these names made two columns of one name, and every table and plot built
# from them broke or read the wrong one. `x` itself is not here: the
# setting's row is then named `setting` (setting_column()).
reserved_setting_names <- c("setting", "t", "observed", "residual", "mean", "sd", "lower",
                            "upper", "pred_lower", "pred_upper")

assert_unreserved_columns <- function(columns, arg) {
  clash <- intersect(columns, reserved_setting_names)
  if (length(clash) == 0L) return(invisible(columns))
  griddy_abort("`", arg, "` has column(s) named ", show_some(paste0("`", clash, "`")),
               ", which griddy's prediction and discrepancy tables use for their own ",
               "columns (", paste(reserved_setting_names, collapse = ", "), "): rename ",
               if (length(clash) == 1L) "it" else "them", " (say, `", clash[1], "_x`).",
               class = "input")
}

# Output coordinates: strictly increasing and finite, `n` of them.
as_coordinates <- function(t, n, arg, what) {
  if (is.null(t)) {
    return(as.double(seq_len(n)))
  }
  t <- assert_numeric_vector(t, arg)
  if (length(t) != n) {
    griddy_abort("`", arg, "` must have one value per output: ", n, " ", what,
                 " but `", arg, "` has ", length(t), ".")
  }
  if (n > 1L && any(diff(t) <= 0)) {
    griddy_abort("`", arg, "` must be strictly increasing; it is not at position(s) ",
                 show_some(which(diff(t) <= 0) + 1L), ".")
  }
  t
}

assert_distinct_runs <- function(theta_mat) {
  id <- data.table::frankv(data.table::as.data.table(theta_mat), ties.method = "dense")
  dup <- which(duplicated(id))
  if (length(dup) > 0L) {
    griddy_abort("`theta` has duplicated runs: row(s) ", show_some(dup),
                 " repeat row(s) ", show_some(match(id[dup], id)), ".")
  }
}

warn_constant_columns <- function(theta_mat) {
  const <- colnames(theta_mat)[apply(theta_mat, 2, function(v) all(v == v[1]))]
  if (length(const) > 0L) {
    griddy_warn("`theta` column(s) ", show_some(const), " are constant across runs: ",
                 "they cannot be calibrated and their interval will be a single value.")
  }
}

# The number of x settings: the rows of `x`, or 1 without x.
n_settings <- function(x) if (is.null(x)) 1L else nrow(x)
