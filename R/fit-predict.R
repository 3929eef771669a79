#' Posterior predictive at the field's settings
#'
#' The simulator outputs at the drawn library runs (the calibrated model), and
#' the same with the fitted misfit added: noise drawn from
#' \eqn{N(0, \tau^{-1} R_x \otimes R_t)} at each draw's \eqn{\tau} and
#' \eqn{\rho}. Compare the second with the field data for a posterior
#' predictive check.
#'
#' @param object A `griddy_fit` from [calibrate()].
#' @param newdata `NULL` (all of the library's x settings), or a data.frame
#'   of x settings, with the library's x columns: the prediction is then at
#'   those settings, in that order, at every t of the library (a `t` column
#'   is not read). A library holds the simulator's outputs at its own
#'   settings only: other settings need `simulator`, or an
#'   [emulated_library()] whose design reaches them (see Details, New
#'   settings), and are otherwise an error of class
#'   `griddy_error_prediction`.
#' @param level Probability of the central intervals.
#' @param ndraws How many draws (evenly spaced over the kept ones) to add noise
#'   (and with `discrepancy = TRUE` the discrepancy) to, for the bounds; the
#'   mean, and the bounds of the simulator alone, use every kept draw.
#' @param seed `NULL`, or a seed for the noise draws of this call only.
#' @param discrepancy For a fit with a [gp_discrepancy()]: `TRUE` to predict
#'   the simulator plus the discrepancy (bias-corrected), `FALSE` the
#'   simulator alone. Must be `FALSE` for a fit without a discrepancy.
#' @param simulator `NULL`, or for `newdata` with settings the library does
#'   not hold, the simulator as a `function(theta, x)`: `theta` a data.frame
#'   of parameter rows (named as the library's), `x` a data.frame of the new
#'   settings (the library's x columns); it returns a numeric matrix with
#'   one row per `theta` row and the outputs at those settings in the
#'   library's layout: blocks of the library's t values, one block per row
#'   of `x`. Not called at the library's own settings.
#' @param run_mass The share of the posterior draws whose runs the simulator
#'   is run at, most visited runs first: the default 0.999 leaves out the
#'   rarest runs, which carry at most 0.1% of the posterior (the bands at the
#'   new settings are over the draws of the runs kept); 1 runs every
#'   distinct run drawn.
#' @param ... Ignored.
#' @return A data.frame with one row per library output at the settings
#'   predicted (the library's order, or `newdata`'s), measured or not: `x`
#'   (the row of the library's x settings; named `setting` when an x column
#'   is itself named `x`), the x columns, `t`,
#'   `observed` (the field data, the mean of a cell's replicates, `NA`
#'   where missing), `mean`, `lower` and
#'   `upper` (the simulator outputs at the drawn runs, plus the discrepancy
#'   with `discrepancy = TRUE`) and `pred_lower`,
#'   `pred_upper` (with noise: each noise group's at its own precision, times
#'   the field's relative `sd` where given, `NA` where the field has no sd;
#'   for one measurement, also where the field has replicates: a replicated
#'   cell's sd is \eqn{\sqrt{n_{rep} / \sum_r sd_r^{-2}}}, its replicates'
#'   when they share one).
#' @details
#' **New settings.** At x settings the library does not hold, `predict()`
#' runs `simulator` at the posterior's distinct runs (those carrying
#' `run_mass` of the draws, each weighted by its draws) and the new
#' settings, in chunks through the runner of [simulate_library()], on the
#' workers of any [future::plan()]. A run that fails, or outputs of the
#' wrong shape, stop the prediction (class `griddy_error_simulator`, with the
#' class of the failure, e.g. `griddy_error_shape`). `mean`, `lower` and
#' `upper` are then over the simulator's outputs at the drawn runs (plus
#' the discrepancy with `discrepancy = TRUE`), `pred_lower` and
#' `pred_upper` add the noise of a new measurement at each draw's
#' \eqn{\tau}: independent across the new settings (and of the field's
#' noise), correlated over t by \eqn{R_t} at the draw's \eqn{\rho_t},
#' times the field's relative `sd` at that t where the field gives one
#' sd, the same at every setting (else `NA`). Noise groups must depend on t
#' only (one group, or labels per output coordinate). Rows of `newdata` at
#' library settings are predicted from the library as without `simulator`
#' (the same answer); `x` and `observed` are `NA` at new settings.
#'
#' With a discrepancy its Gaussian process extends to the new settings:
#' given each draw's run, grid point and \eqn{\tau}, \eqn{\delta} at the
#' new cells is the Gaussian conditional on the field's residuals at the
#' measured cells, under the kernel over the library's cells and the new
#' ones (the new x scaled as the library's, so beyond \[0, 1] outside its
#' range), conditioned on `zero_at` and `flat_at` (\eqn{K^*}) as the fit's
#' is. Far from the measured settings its mean reverts to 0 and its
#' variance to the prior's \eqn{\lambda / \tau}: an extrapolation's band
#' widens by the discrepancy's whole prior spread. An orthogonal
#' discrepancy's projection removes from \eqn{\delta} at the library's
#' cells the part a change of \eqn{\theta} imitates; the same change of
#' \eqn{\theta} moves the new cells too, by the simulator's sensitivities
#' there (the slopes of its outputs on \eqn{\theta} over the 4p + 2, at
#' least 12, runs nearest the most visited one, which `simulator` is also
#' run at), and that move is removed there as well, so the prediction is of
#' the same \eqn{\theta} (the best-fitting one) at every setting. Far out,
#' the projection's share grows with the sensitivities, so an orthogonal
#' discrepancy's mean need not revert to 0 there.
#'
#' **Without a discrepancy** the fit assumes the simulator is right at every
#' setting, so beyond the measured settings its band is the simulator's
#' spread over the posterior plus the noise: nothing in it grows with the
#' distance from the measurements, and it can be as narrow outside the
#' measured range as inside (as measured in `vignette("prediction")`). New
#' settings outside the range of the measured settings (per x column; library
#' settings without field data do not count) give a warning of class
#' `griddy_warning_extrapolation` that says so.
#'
#' **Without a simulator**, new settings are predicted from an emulator over
#' x where the library has one: a library built by [emulated_library()]
#' (or [read_calibration_inputs()] from a design; also as the base of a
#' [refine()]d library) whose design reaches them. "Reaches" means: every
#' x column of the new setting lies inside the design runs' range of that
#' column, give or take 5% of its width, the range inside which
#' [emulated_library()] does not warn of extrapolation. A joint design's
#' emulator, \eqn{(x, \theta) \to} outputs, predicts there as it predicted
#' the library; a design complete at the library's settings has an
#' emulator of \eqn{\theta} only, so a joint one is fitted to its runs for
#' the new settings (RobustGaSP, once per call). The emulator's mean stands
#' for the simulator's outputs at the posterior's runs, and its predictive
#' sd for its error: each draw adds a Gaussian error of that sd to its run's
#' outputs, so `lower`, `upper`, `pred_lower` and `pred_upper` carry the
#' emulation error (pointwise; `mean` is unchanged by it). Inside the range
#' the sd grows where the design is sparse (corners of a joint design's
#' \eqn{(x, \theta)} box that no run visited), and the bands with it.
#' Beyond the range, where the emulator reverts to its mean and its error
#' is unmeasured, and for any other library, new settings are an error of
#' class `griddy_error_prediction` that names what does not reach them. (At
#' the library's own settings the bands are today's, without the emulator's
#' error, which the likelihood carried.)
#' @seealso [predict.griddy_stream()], the same from a [griddy_stream()]'s exact posterior.
#' @references Bayarri, M. J., Berger, J. O., Paulo, R., Sacks, J., Cafeo,
#'   J. A., Cavendish, J., Lin, C.-H. and Tu, J. (2007). A framework for
#'   validation of computer models. *Technometrics* 49(2), 138-154.
#' @examples
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 1000, burn_in = 200, seed = 1)
#' head(predict(fit, ndraws = 200, seed = 1))
#' predict(fit, newdata = data.frame(mass = 2), ndraws = 200, seed = 1)
#' fit_d <- calibrate(ex$library, ex$field, n_iter = 1000, burn_in = 200, seed = 1,
#'                    discrepancy = gp_discrepancy(length_x = 1, length_t = c(0.3, 1)))
#' corrected <- predict(fit_d, ndraws = 200, seed = 1)
#' simulator <- predict(fit_d, ndraws = 200, seed = 1, discrepancy = FALSE)
#'
#' # Beyond the library: the simple machine (simulator theta x, reality
#' # theta x / (1 + x / 20)), calibrated on x in [0.2, 4], predicted at 5 and
#' # 6, where reality is 2.6 and 3
#' x <- data.frame(x = seq(0.2, 4, length.out = 11))
#' theta <- data.frame(theta = seq(0.3, 1, by = 0.0025))
#' lib <- sim_library(theta, outer(theta$theta, x$x), x = x)
#' set.seed(1)
#' field <- field_data(matrix(0.65 * x$x / (1 + x$x / 20) + rnorm(11, sd = 0.01)), x = x)
#' fit_m <- calibrate(lib, field, n_iter = 2000, burn_in = 200, seed = 1,
#'                    discrepancy = gp_discrepancy())
#' machine <- function(theta, x) outer(theta$theta, x$x)
#' predict(fit_m, newdata = data.frame(x = c(2, 5, 6)), simulator = machine, seed = 1)
#' # the simulator alone misses reality there
#' predict(fit_m, newdata = data.frame(x = c(5, 6)), simulator = machine, seed = 1,
#'         discrepancy = FALSE)
#' @export
predict.griddy_fit <- function(object, newdata = NULL, level = 0.95, ndraws = 1000,
                               seed = NULL, discrepancy = has_discrepancy(object),
                               simulator = NULL, run_mass = 0.999, ...) {
  assert_level(level)
  ndraws <- assert_count(ndraws, "ndraws")
  seed <- assert_seed(seed)
  discrepancy <- assert_flag(discrepancy, "discrepancy")
  if (discrepancy) assert_discrepancy_fit(object)
  lib <- object$library
  # settings the library does not hold: the simulator's route (fit-predict-new.R)
  hit <- new_setting_rows(lib, newdata)
  if (!is.null(hit)) {
    return(predict_new_settings(object, newdata, hit, level, ndraws, seed, discrepancy,
                                simulator, run_mass))
  }
  settings <- predict_settings(lib, newdata)
  cols <- as.vector(outer(seq_len(lib_n_t(lib)), (settings - 1L) * lib_n_t(lib), "+"))
  probs <- c((1 - level) / 2, 1 - (1 - level) / 2)
  freq <- tabulate(object$draws$run, nbins = lib_n_runs(lib))
  visited <- which(freq > 0)
  Y <- lib_outputs(lib, visited)[, cols, drop = FALSE]
  w <- freq[visited] / sum(freq)
  mean <- colSums(Y * w)
  pick <- evenly_spaced_draws(object, ndraws)
  if (discrepancy) {
    # the same draws' discrepancy joins their outputs and their noise
    drawn <- with_seed(seed, list(delta = discrepancy_draws(object, pick),
                                  noisy = noisy_outputs(object, pick)))
    delta <- drawn$delta[, cols, drop = FALSE]
    noisy <- drawn$noisy[, cols, drop = FALSE] + delta
    mean <- mean + discrepancy_moments(object)$mean[cols]
    corrected <- lib_outputs(lib, object$draws$run[pick])[, cols, drop = FALSE] + delta
    bounds <- apply(corrected, 2, stats::quantile, probs = probs, names = FALSE)
  } else {
    bounds <- apply(Y, 2, weighted_quantile, w = w, probs = probs)
    noisy <- with_seed(seed, noisy_outputs(object, pick))[, cols, drop = FALSE]
  }
  pred <- apply(noisy, 2, stats::quantile, probs = probs, names = FALSE, na.rm = TRUE)
  cbind(setting_cells(lib, settings), observed = object$y_field[cols],
        mean = mean, lower = bounds[1, ], upper = bounds[2, ],
        pred_lower = pred[1, ], pred_upper = pred[2, ])
}

# One row per output at x settings `settings` (rows of the library's x), in
# that order: the setting's row, the x columns and `t`; the first columns
# of predict()'s and discrepancy_posterior()'s tables.
setting_cells <- function(lib, settings) {
  n_t <- lib_n_t(lib)
  rows <- rep(settings, each = n_t)
  out <- stats::setNames(data.frame(rows), setting_column(lib))
  if (!is.null(lib_x(lib))) out <- cbind(out, lib_x(lib)[rows, , drop = FALSE])
  out$t <- rep(lib_t(lib), length(settings))
  rownames(out) <- NULL
  out
}

# The name of the column that holds a setting's row: `x`, unless an x
# column is itself named `x` (its values then keep the name, and two
# columns of one name broke every table and plot built from them).
setting_column <- function(lib) if ("x" %in% names(lib_x(lib))) "setting" else "x"

# The library x settings (row numbers) that `newdata` names.
predict_settings <- function(lib, newdata) {
  n_x <- lib_n_x(lib)
  if (is.null(newdata)) return(seq_len(n_x))
  if (!is.data.frame(newdata) || nrow(newdata) < 1L) {
    griddy_abort("`newdata` must be NULL or a data.frame of x settings; received ",
                 class(newdata)[1], if (is.data.frame(newdata)) " with no rows", ".")
  }
  x_lib <- lib_x(lib)
  if (is.null(x_lib)) {
    griddy_abort("`newdata` cannot be used: the library has a single x setting and no x ",
                 "columns, so predict() predicts there (use newdata = NULL).")
  }
  missing_cols <- setdiff(names(x_lib), names(newdata))
  if (length(missing_cols) > 0L) {
    griddy_abort("`newdata` lacks the library's x column(s) ", show_some(missing_cols), ".")
  }
  nd <- as_numeric_matrix(newdata[names(x_lib)], "newdata")
  hit <- match_setting_rows(as.data.frame(nd), x_lib)
  if (anyNA(hit)) {
    bad <- which(is.na(hit))
    griddy_abort("`newdata` row(s) ", show_some(bad), " (", show_some(apply(
      nd[bad, , drop = FALSE], 1, function(v) paste0(names(x_lib), " = ", v, collapse = ", "))),
      ") are not x settings of the library: griddy predicts from the simulator runs it ",
      "has, which are at the library's settings only (", n_x, " setting(s)).")
  }
  hit
}

# The smallest value whose cumulative weight reaches each probability (also
# the interval of resolution_table(), resolution.R).
weighted_quantile <- function(v, w, probs) {
  o <- order(v)
  cw <- cumsum(w[o])
  v[o][vapply(probs, function(p) which(cw >= p - 1e-12)[1], integer(1))]
}

# Library outputs at the chosen draws plus N(0, S R_g S / tau) noise at every
# output, observed or not: one row per draw, the noise coloured by each
# draw's grid point (engine.R); with noise groups, independent noise
# for each group at its own tau_k, correlated within it; S the field's
# relative sd (NA, so no predictive bound, where the field gives none).
noisy_outputs <- function(fit, pick) {
  lib <- fit$library
  n_x <- lib_n_x(lib)
  n_t <- lib_n_t(lib)
  d <- fit$draws[pick, ]
  tau <- as.matrix(d[tau_columns(fit)])
  pattern <- fit$setup$pattern
  out <- lib_outputs(lib, d$run)
  for (g in unique(d$grid_point)) {
    rows <- which(d$grid_point == g)
    point <- grid_point(fit$setup, g)
    for (k in seq_len(ncol(tau))) {
      Z <- matrix(stats::rnorm(length(rows) * n_x * n_t), length(rows), byrow = TRUE)
      noise <- colour_rows(Z, point, n_x, n_t) / sqrt(tau[rows, k])
      cols <- if (ncol(tau) == 1L) seq_len(n_x * n_t) else which(pattern$group == k)
      if (!is.null(pattern$sd)) noise <- sweep(noise, 2, pattern$sd, "*")
      out[rows, cols] <- out[rows, cols] + noise[, cols]
    }
  }
  out
}
