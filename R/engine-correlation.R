# The correlation functions R = R_x (x) R_t of thesis Appendix B and the grid
# of their parameters; what one grid point holds is in engine.R.
#
# R_x[k, l] = prod_j rho_j ^ (4^(p - 1) |x_kj - x_lj|^p), x scaled to [0, 1] per
#   column: p = 2 gives eq. 3.14 (rho^(4 d^2)), p = 1 Appendix A's eq. 5 (rho^|d|).
# R_t[j, m] = rho_t ^ |t_j - t_m|, t scaled to [0, 1]: an AR(1) process, whose
#   log-determinant is sum_j log(1 - phi_j^2) with phi_j = rho_t^(t_{j+1} - t_j)
#   (eq. 11-12 on an even grid).

#' Correlation grid of a calibration
#'
#' Lists every combination of the correlation parameters that [calibrate()]
#' and [posterior_exact()] move over: one grid for each x column (all
#' combinations taken, as the thesis's Appendix A assembles them) and one for
#' the output coordinate t.
#'
#' **Prior over the grid.** [calibrate()] and [posterior_exact()] put a
#' uniform prior over the distinct correlation structures \eqn{R_g}, not over
#' grid points: grid points whose \eqn{R_g} coincide share one structure's
#' mass. This matters for more than one x column: \eqn{\rho_j = 0} makes
#' \eqn{R_x} the identity whatever the other columns' \eqn{\rho} when every
#' setting differs in column \eqn{j}, so a prior uniform over grid points
#' would favour independence (with 6 values for each of 2 columns, 11 of the
#' 36 grid points are independence; it gets 1/26 of the prior, as each of
#' the other 25 structures does).
#'
#' @param library A [sim_library()].
#' @param rho_x Correlation over the control settings, in \[0, 1): a vector
#'   (the same grid for every x column) or a list with one grid per x column.
#'   0 means independent settings.
#' @param rho_t Correlation over the output coordinate t (scaled to \[0, 1]),
#'   in \[0, 1): a vector. On an even grid of `n_t` points, neighbouring
#'   outputs have correlation `rho_t^(1 / (n_t - 1))`.
#' @return A data.frame with one row per grid point and one column per
#'   correlation parameter: `rho_x_<name>` for each x column (when the library
#'   has more than one x setting) and `rho_t` (when it has more than one
#'   output per setting).
#' @examples
#' lib <- sim_library(data.frame(k = 1:3), matrix(rnorm(18), 3, 6),
#'                    x = data.frame(height = c(1, 2)))
#' rho_grid(lib, rho_x = c(0, 0.5), rho_t = c(0, 0.1, 0.9))
#' @export
rho_grid <- function(library, rho_x = 0, rho_t = 0) {
  check_library(library)
  grid_table(library, rho_grids(library, rho_x, rho_t))
}

# The grid as a table from validated grids (rho_grids()): the correlation
# parameters that vary in this library.
grid_table <- function(library, grids) {
  grid <- expand.grid(c(grids$x, list(rho_t = grids$t)), KEEP.OUT.ATTRS = FALSE)
  keep <- c(if (lib_n_x(library) > 1L) names(grids$x), if (lib_n_t(library) > 1L) "rho_t")
  grid[keep]
}

# Validated grids: a named list of grids per x column, and the t grid.
rho_grids <- function(library, rho_x, rho_t) {
  x_names <- if (is.null(lib_x(library))) "x" else names(lib_x(library))
  if (is.list(rho_x)) {
    if (length(rho_x) != length(x_names)) {
      griddy_abort("`rho_x` must hold one grid per x column (", show_some(x_names),
                   "); received ", length(rho_x), ".")
    }
    if (!is.null(names(rho_x)) && !setequal(names(rho_x), x_names)) {
      griddy_abort("`rho_x` names (", show_some(names(rho_x)),
                   ") must be the x columns (", show_some(x_names), ").")
    }
    if (!is.null(names(rho_x))) rho_x <- rho_x[x_names]
  } else {
    rho_x <- rep(list(rho_x), length(x_names))
  }
  names(rho_x) <- paste0("rho_x_", x_names)
  rho_x <- Map(assert_rho_grid, rho_x, paste0("rho_x$", x_names))
  rho_t <- assert_rho_grid(rho_t, "rho_t")
  if (lib_n_x(library) == 1L && any(unlist(rho_x) != 0)) {
    griddy_abort("`rho_x` must be 0: the library has a single x setting, so there is ",
                 "nothing to correlate.")
  }
  if (lib_n_t(library) == 1L && any(rho_t != 0)) {
    griddy_abort("`rho_t` must be 0: the library has a single output per x setting, ",
                 "so there is nothing to correlate.")
  }
  list(x = rho_x, t = rho_t)
}

# Scale each column (or a vector) to [0, 1]; constant columns become 0.
scale_unit <- function(v) {
  span <- max(v) - min(v)
  if (span > 0) (v - min(v)) / span else v * 0
}

# R_x at one combination of per-column correlations `rho` (one per x column):
# the product of the columns' factors (corr_x_factor()), in column order.
corr_x <- function(x, rho, power = 2) {
  n_x <- n_settings(x)
  R <- matrix(1, n_x, n_x)
  if (n_x == 1L) {
    return(R)
  }
  for (j in seq_along(rho)) R <- R * corr_x_factor(x[[j]], rho[j], power)
  R
}

# The factor of R_x from one x column `v` at correlation `rho`.
corr_x_factor <- function(v, rho, power) {
  d <- 4^(power - 1) * abs(outer(scale_unit(v), scale_unit(v), "-"))^power
  if (rho == 0) (d == 0) * 1 else rho^d
}

# R_x at every combination of the x grids (a list, one grid per x column),
# in the order of expand.grid(): each column's factors computed once per
# value, not once per combination. The same matrices as corr_x().
corr_x_grid <- function(x, grids, power = 2) {
  combos <- as.matrix(expand.grid(lapply(grids, seq_along), KEEP.OUT.ATTRS = FALSE))
  if (is.null(x) || nrow(x) == 1L) {
    return(lapply(seq_len(nrow(combos)), function(k) matrix(1)))
  }
  factors <- Map(function(v, grid) lapply(grid, corr_x_factor, v = v, power = power),
                 x, grids)
  lapply(seq_len(nrow(combos)), function(k) {
    R <- matrix(1, nrow(x), nrow(x))
    for (j in seq_along(factors)) R <- R * factors[[j]][[combos[k, j]]]
    R
  })
}

# Lag coefficients of the AR(1) correlation over t: phi_j = rho^(s_{j+1} - s_j).
ar1_phi <- function(t, rho) {
  if (length(t) < 2L) {
    return(numeric(0))
  }
  gaps <- diff(scale_unit(t))
  if (rho == 0) gaps * 0 else rho^gaps
}

# Dense R_t, for tests and for drawing correlated noise in small problems.
corr_t <- function(t, rho) {
  s <- scale_unit(t)
  d <- abs(outer(s, s, "-"))
  if (rho == 0) (d == 0) * 1 else rho^d
}
