# Simulator outputs at output coordinates the runs were not written at: the
# field's heights or times between the simulator's (SEPIA's ball drop 1 times
# the fall at 5, 10, 15 and 20 m, its simulator at 1.5, 3, ..., 24 m). Each
# run's outputs are interpolated along t by a cubic spline, before a library
# is formed or emulated from the runs (read_calibration_inputs(t_field =),
# emulated_library(t_out =)), so the field data need no reshaping by hand.
#
# A cubic spline through n values is linear in them, so one n_from x n_to
# matrix interpolates every run: y_to = y_from %*% M. The interpolation
# error is estimated by leaving each interior coordinate out in turn
# (interpolating it from the others, at twice the local spacing, so the
# estimate errs on the large side) and is reported with the result.

# The matrix M with splinefun(t_from, y, "fmm")(t_to) = y %*% M for any y:
# the spline of each unit vector. Two coordinates interpolate linearly.
spline_matrix <- function(t_from, t_to) {
  n <- length(t_from)
  by_unit <- vapply(seq_len(n), function(j) {
    stats::splinefun(t_from, as.numeric(seq_len(n) == j), method = "fmm")(t_to)
  }, numeric(length(t_to)))
  t(matrix(by_unit, nrow = length(t_to)))
}

# The outputs `y` (one row per run; `n_blocks` blocks of length(t_from)
# columns, one per x setting) at the coordinates `t_to`, each block
# interpolated along t. Attribute "loo_rms": the root mean square error of
# interpolating each interior coordinate from the others, over all runs and
# blocks (NA with fewer than 3 coordinates). Coordinates of `t_to` outside
# t_from's range are refused: a spline extrapolates badly.
interpolate_outputs <- function(y, t_from, t_to, arg = "t_field", n_blocks = 1L) {
  outside <- t_to < min(t_from) - 1e-8 * max(1, abs(min(t_from))) |
    t_to > max(t_from) + 1e-8 * max(1, abs(max(t_from)))
  if (any(outside)) {
    griddy_abort("`", arg, "` must lie within the simulator's output coordinates `t` (",
                 format(min(t_from)), " to ", format(max(t_from)), "): ",
                 show_some(format(t_to[outside])), " lie outside, where interpolating the ",
                 "runs would extrapolate them; run the simulator there.", class = "input")
  }
  n_from <- length(t_from)
  M <- spline_matrix(t_from, pmin(pmax(t_to, min(t_from)), max(t_from)))
  block_cols <- function(k, n) (k - 1L) * n + seq_len(n)
  out <- do.call(cbind, lapply(seq_len(n_blocks), function(k) {
    y[, block_cols(k, n_from), drop = FALSE] %*% M
  }))
  dimnames(out) <- NULL
  squares <- unlist(lapply(seq_len(n_blocks), function(k) {
    loo_interpolation_residuals(y[, block_cols(k, n_from), drop = FALSE], t_from)
  }))
  structure(out, loo_rms = if (length(squares)) sqrt(mean(squares^2)) else NA_real_)
}

# The residuals of interpolating each interior coordinate of `t` from the
# others, for every row of `y` (numeric(0) with fewer than 3 coordinates).
loo_interpolation_residuals <- function(y, t) {
  n <- length(t)
  if (n < 3L) return(numeric(0))
  unlist(lapply(seq(2L, n - 1L), function(j) {
    y[, j] - y[, -j, drop = FALSE] %*% spline_matrix(t[-j], t[j])
  }))
}

# Validated output coordinates to interpolate to: NULL, or finite and
# strictly increasing.
assert_output_coordinates <- function(t_to, arg) {
  if (is.null(t_to)) return(NULL)
  t_to <- assert_numeric_vector(t_to, arg)
  if (length(t_to) > 1L && any(diff(t_to) <= 0)) {
    griddy_abort("`", arg, "` must be strictly increasing; it is not at position(s) ",
                 show_some(which(diff(t_to) <= 0) + 1L), ".", class = "input")
  }
  t_to
}

# The message said when runs are interpolated along t.
inform_interpolated <- function(n_from, t_to, loo_rms) {
  cli::cli_inform(c(
    i = paste0("The runs' {n_from} outputs were interpolated along t (cubic spline) to the ",
               "{length(t_to)} coordinate(s) of the field data."),
    i = paste0("Leaving each interior coordinate out, the interpolation error (RMS) is ",
               "{format(loo_rms, digits = 3)}; it is not in the likelihood, so it should ",
               "be small against the noise.")),
    class = "griddy_message_interpolated")
}
