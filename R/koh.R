#' Traditional Kennedy-O'Hagan calibration as a baseline (RobustCalibration)
#'
#' Runs the calibration a user would choose instead of Griddy Gibbs: a
#' Gaussian-process emulator of the simulator trained on a (small) library,
#' a Gaussian-process discrepancy (or none) and random-walk Metropolis within
#' Gibbs, as implemented by the CRAN package 'RobustCalibration' (Gu), with
#' the emulator from 'RobustGaSP'. Both packages are optional (Suggests).
#' With `discrepancy = "none"` it is the baseline of the thesis's chapter 4,
#' whose traditional calibration had no discrepancy in its data model; see
#' `vignette("chapter4")`.
#'
#' The emulator is one parallel partial Gaussian process
#' ([RobustGaSP::ppgasp()], no nugget) from the library's parameters to all
#' its outputs, fitted once and passed to [RobustCalibration::rcalibration()]
#' as the math model, so the sampler evaluates the emulator's predictive mean
#' at each proposed \eqn{\theta} (a closed form whose weights are solved
#' once: the chain costs what [RobustCalibration::rcalibration()] costs on
#' that model called directly; the emulator's fit and the pilot runs are
#' timed apart in `runtime`). The discrepancy is a GP (`"GaSP"`), a scaled
#' GP (`"S-GaSP"`, Gu and Wang 2018) over the observations' inputs (the
#' library's x settings, and t if any), or absent (`"none"`,
#' RobustCalibration's `"no-discrepancy"`: the data are the emulator's mean
#' plus independent noise of unknown variance). The prior
#' on \eqn{\theta} is uniform on the range of the library's parameters.
#'
#' Proposal scale. 'RobustCalibration' proposes all of \eqn{\theta} at once
#' with standard deviations given as fractions of the parameter ranges (its
#' default, 0.05 times the range, is meant for parameters on \[0, 1\]; on
#' other scales it is multiplied by the range twice). With `proposal_sd =
#' NULL` this function tunes the fractions by `tune_rounds` pilot runs of
#' `tune_iter` iterations each, starting at 2% of the range: after each round
#' the fractions become \eqn{2.38/\sqrt{p}} times the pilot's posterior
#' standard deviations (or a fifth of the previous ones if the round accepted
#' under 5% of the moves). The main run starts from the last pilot draw.
#'
#' @param library A [sim_library()]: the emulator's training runs (the thesis
#'   used 7 values per parameter, 343 runs); or an [emulated_library()], whose
#'   own emulator of its design runs is then the math model (its predicted
#'   runs are not used), the prior on \eqn{\theta} uniform on its range.
#' @param field A [field_data()] object at the library's x and t. Missing
#'   cells are left out of the likelihood. Replicated measurements are passed
#'   to RobustCalibration as it takes them (a row of replicates per cell: the
#'   cells' means and their pure error) when every measured cell has the
#'   same number; unequal replicates and a relative `sd` are not supported
#'   (an error of class `griddy_error_unsupported`; [calibrate()] takes
#'   them).
#' @param discrepancy `"GaSP"`, `"S-GaSP"` or `"none"`.
#' @param n_iter Total MCMC iterations, burn-in included.
#' @param burn_in Iterations discarded at the start.
#' @param proposal_sd `NULL` (tune, see Details) or the proposal standard
#'   deviations of \eqn{\theta} as fractions of each parameter's range.
#' @param tune_rounds,tune_iter Number and length of the pilot runs.
#' @param kernel Discrepancy kernel: `"matern_5_2"`, `"matern_3_2"` or
#'   `"pow_exp"`.
#' @param seed `NULL`, or a seed for this call only (the global random number
#'   stream is left as it was).
#' @param progress Show the two packages' console output (their progress);
#'   silent by default outside interactive sessions.
#' @param quiet Deprecated: use `progress = !quiet`. Still honoured, with a
#'   warning of class `griddy_warning_deprecated`.
#' @param control Settings shared by the calibrating functions, from
#'   [griddy_control()]; an argument given in the call overrides its field.
#'
#' @section Library size: The emulator estimates a range parameter per
#'   parameter besides its mean and variance, so a library of `p` parameters
#'   needs at least `p + 2` runs (an [emulated_library()]: design runs);
#'   smaller ones are refused with an error of class
#'   `griddy_error_library_size` (with 2 runs of 2 parameters the sampler
#'   printed hundreds of "NaNs produced" warnings and returned a confident
#'   interval). That is a floor, not a recommendation: about 10 runs per
#'   parameter is the usual rule for a GP emulator (Loeppky, Sacks and Welch
#'   2009). Warnings of non-finite values ("NaNs produced") from the sampler
#'   are gathered into one warning of class `griddy_warning_koh_numerics`
#'   saying how many there were.
#' @return An object of class `griddy_koh`: a list holding the kept `draws` (a
#'   data.frame with `iteration`, one column per parameter, and `sigma2`:
#'   the noise variance, RobustCalibration's \eqn{\sigma_0^2}; with a
#'   discrepancy, its variance is `sigma2` over the sampled nugget
#'   parameter), the `parameters`' names, the fitted `emulator` (a list: the [RobustGaSP::ppgasp()] fit
#'   `gp` of the outputs that vary over the runs, `vary`, and `constant`),
#'   the `discrepancy`, the `proposal_sd` used, the `acceptance` rates of
#'   the \eqn{\theta} and kernel moves, `y_field` (each cell's
#'   measurement, or its replicates' mean), the `design` of the
#'   observations, and the `runtime` in seconds (`emulator`, `tuning`,
#'   `sampling`). Use [summary()][summary.griddy_koh] and
#'   [predict()][predict.griddy_koh] on it.
#' @references Kennedy, M. C. and O'Hagan, A. (2001). Bayesian calibration of
#'   computer models. JRSS B 63(3), 425-464.
#'
#'   Gu, M. and Wang, L. (2018). Scaled Gaussian stochastic process for
#'   computer model calibration and prediction. SIAM/ASA JUQ 6(4), 1555-1583.
#' @seealso [calibrate()] for Griddy Gibbs on the same objects.
#' @examplesIf requireNamespace("RobustCalibration", quietly = TRUE)
#' f <- piston_field_data(15, seed = 1)
#' lib <- piston_library(4, locations = attr(f, "locations"))
#' koh <- koh_calibrate(lib, f, n_iter = 1500, burn_in = 500, tune_iter = 300,
#'                      seed = 1)
#' koh
#' summary(koh)
#' @export
koh_calibrate <- function(library, field, discrepancy = c("GaSP", "S-GaSP", "none"),
                          n_iter = control$n_iter, burn_in = control$burn_in,
                          proposal_sd = NULL,
                          tune_rounds = 3, tune_iter = 1000, kernel = "matern_5_2",
                          seed = NULL, progress = control$progress, quiet,
                          control = griddy_control()) {
  control <- assert_control(control)
  for (pkg in c("RobustCalibration", "RobustGaSP")) {
    if (!requireNamespace(pkg, quietly = TRUE)) {
      griddy_abort("koh_calibrate() needs the package '", pkg,
                   "': install.packages(\"RobustCalibration\").", class = "package")
    }
  }
  discrepancy <- assert_choice(discrepancy, "discrepancy", c("GaSP", "S-GaSP", "none"),
                               vector_default = TRUE)
  kernel <- assert_choice(kernel, "kernel", c("matern_5_2", "matern_3_2", "pow_exp"))
  n_iter <- assert_count(n_iter, "n_iter", min = 2L)
  burn_in <- assert_count(burn_in, "burn_in", min = 0L)
  if (burn_in >= n_iter) {
    griddy_abort("`burn_in` must be smaller than `n_iter`; received ", burn_in,
                 " and ", n_iter, ".")
  }
  tune_rounds <- assert_count(tune_rounds, "tune_rounds", min = 0L)
  tune_iter <- assert_count(tune_iter, "tune_iter", min = 10L)
  progress <- assert_flag(progress, "progress")
  if (!missing(quiet)) {
    quiet <- assert_flag(quiet, "quiet")
    griddy_warn("`quiet` is deprecated in koh_calibrate(): use `progress = ", !quiet,
                "` (as every other griddy function says).", class = "deprecated")
    progress <- !quiet
  }
  quiet <- !progress
  check_library(library)
  if (!is.null(field$sd)) {
    griddy_abort("koh_calibrate() does not yet support field data with a relative `sd`; ",
                 "calibrate() does.", class = "unsupported")
  }
  obs <- koh_observations(library, field)
  y <- obs$y
  # missing measurements are no observations: KOH's likelihood is over the
  # observed cells (the design and math model are cut to them)
  observed <- !is.na(y)
  theta <- as.matrix(lib_theta(library))
  p <- ncol(theta)
  if (!is.null(proposal_sd)) {
    proposal_sd <- assert_numeric_vector(proposal_sd, "proposal_sd")
    if (length(proposal_sd) != p || any(proposal_sd <= 0)) {
      griddy_abort("`proposal_sd` must hold ", p, " positive fractions of the ranges; received ",
                   paste(format(proposal_sd), collapse = ", "), ".")
    }
  }
  assert_koh_library_size(library, p)
  theta_range <- cbind(apply(theta, 2, min), apply(theta, 2, max))
  if (any(theta_range[, 2] <= theta_range[, 1])) {
    griddy_abort("Every library parameter must vary for koh_calibrate(); constant: ",
                 show_some(colnames(theta)[theta_range[, 2] <= theta_range[, 1]]), ".")
  }
  design <- koh_design(library, observed)
  obs_design <- design[observed, , drop = FALSE]
  type <- if (discrepancy == "none") "no-discrepancy" else discrepancy
  n_x <- ncol(obs_design)
  run <- function() {
    t0 <- proc.time()[["elapsed"]]
    design_gp <- lib_design_emulator(library)
    emulator <- if (!is.null(design_gp)) {
      # its own emulator of the design runs, not one of its predicted runs
      list(design_gp = design_gp)
    } else {
      koh_emulator(theta, lib_outputs(library), quiet)
    }
    math_model <- koh_math_model(emulator, observed)
    t1 <- proc.time()[["elapsed"]]
    sampler <- function(sd_frac, S, S_0, start) {
      sd_all <- if (type == "no-discrepancy") sd_frac else c(sd_frac, rep(0.25, n_x), 0.25)
      koh_quietly(quiet, RobustCalibration::rcalibration(
        design = obs_design, observations = obs$values, p_theta = p, simul_type = 1,
        math_model = math_model, theta_range = theta_range, sd_proposal = sd_all,
        S = S, S_0 = S_0, discrepancy_type = type, kernel_type = kernel,
        initial_values = start))
    }
    start <- rowMeans(theta_range)
    sd_frac <- if (is.null(proposal_sd)) rep(0.02, p) else proposal_sd
    if (is.null(proposal_sd)) {
      for (r in seq_len(tune_rounds)) {
        pilot <- sampler(sd_frac, tune_iter, 0L, start)
        draws <- as.matrix(pilot@post_sample)[, seq_len(p), drop = FALSE]
        start <- draws[nrow(draws), ]
        half <- draws[-seq_len(nrow(draws) %/% 2L), , drop = FALSE]
        accepted <- pilot@accept_S[1] / tune_iter
        spread <- apply(half, 2, stats::sd) / (theta_range[, 2] - theta_range[, 1])
        sd_frac <- if (accepted < 0.05 || any(spread <= 0)) {
          sd_frac / 5
        } else {
          2.38 / sqrt(p) * spread
        }
      }
    }
    t2 <- proc.time()[["elapsed"]]
    main <- sampler(sd_frac, n_iter, burn_in, start)
    t3 <- proc.time()[["elapsed"]]
    list(emulator = emulator, fit = main, sd_frac = sd_frac,
         runtime = c(emulator = t1 - t0, tuning = t2 - t1, sampling = t3 - t2))
  }
  res <- with_seed(assert_seed(seed), koh_numerics(run()))
  post <- as.matrix(res$fit@post_sample)
  draws <- data.frame(iteration = seq(burn_in + 1L, length.out = nrow(post)),
                      post[, seq_len(p), drop = FALSE])
  names(draws)[-1] <- colnames(theta)
  draws$sigma2 <- post[, ncol(post)]
  structure(list(draws = draws, parameters = colnames(theta), emulator = res$emulator,
                 discrepancy = discrepancy, kernel = kernel,
                 proposal_sd = stats::setNames(res$sd_frac, colnames(theta)),
                 acceptance = c(theta = res$fit@accept_S[1],
                                kernel = if (type == "no-discrepancy") NA else
                                  res$fit@accept_S[2]) / n_iter,
                 y_field = y, design = design, theta_range = theta_range,
                 n_runs = koh_training_runs(library), control = list(n_iter = n_iter, burn_in = burn_in),
                 runtime = res$runtime),
            class = "griddy_koh")
}

# The runs the emulator is trained on: the library's, or an emulated
# library's design runs.
koh_training_runs <- function(library) {
  if (inherits(library, "emulated_library")) emulated_design_runs(library) else lib_n_runs(library)
}

# An emulator of p parameters estimates p range parameters, a mean and a
# variance: fewer than p + 2 runs leave it undetermined (2 runs of 2
# parameters gave hundreds of NaN warnings and a confident interval).
assert_koh_library_size <- function(library, p) {
  n <- koh_training_runs(library)
  if (n < p + 2L) {
    griddy_abort("koh_calibrate() needs a library of at least ", p + 2L, " runs for its ",
                 "Gaussian-process emulator of ", p, " parameters (a range parameter each, a ",
                 "mean and a variance); this one has ", n, " runs",
                 if (inherits(library, "emulated_library")) " in its design", ". About ",
                 10L * p, " runs (10 per parameter) is the usual rule; calibrate() works ",
                 "on the library as it is.", class = "library_size")
  }
  invisible(n)
}

# Runs `expr` (the sampler), gathering base R's "NaNs produced" warnings from
# inside RobustCalibration into one classed warning that says what they mean.
koh_numerics <- function(expr) {
  n_nan <- 0L
  out <- withCallingHandlers(expr, warning = function(w) {
    if (grepl("NaNs produced", conditionMessage(w), fixed = TRUE)) {
      n_nan <<- n_nan + 1L
      invokeRestart("muffleWarning")
    }
  })
  if (n_nan > 0L) {
    griddy_warn("RobustCalibration produced non-finite values (NaN) ", n_nan, " time(s) ",
                "while sampling: its likelihood was undefined at some proposals, so the ",
                "draws may not describe the posterior. A larger library (about 10 runs per ",
                "parameter) or a discrepancy model usually removes them.",
                class = "koh_numerics")
  }
  out
}

# Inputs of the observations, in the library's order (blocks by x setting).
koh_design <- function(library, observed = TRUE) {
  n_x <- lib_n_x(library)
  n_t <- lib_n_t(library)
  x <- if (is.null(lib_x(library))) matrix(0, n_x, 0) else as.matrix(lib_x(library))
  out <- x[rep(seq_len(n_x), each = n_t), , drop = FALSE]
  if (n_t > 1L) out <- cbind(out, t = rep(lib_t(library), n_x))
  if (ncol(out) == 0L) out <- matrix(1, n_x * n_t, 1L, dimnames = list(NULL, "x"))
  out <- matrix(as.numeric(out), nrow(out), dimnames = list(NULL, colnames(out)))
  # the inputs that vary over the observed cells
  keep <- apply(out[observed, , drop = FALSE], 2, function(v) length(unique(v)) > 1L)
  if (!any(keep)) keep[1] <- TRUE
  out[, keep, drop = FALSE]
}

# A ppgasp emulator of the outputs that vary over the runs; the constant ones
# (e.g. a boundary value) are returned as they are.
koh_emulator <- function(theta, y, quiet) {
  vary <- apply(y, 2, function(v) max(v) > min(v))
  gp <- if (any(vary)) {
    koh_quietly(quiet, RobustGaSP::ppgasp(design = theta, response = y[, vary, drop = FALSE],
                                          nugget.est = FALSE))
  }
  list(gp = gp, vary = vary, constant = y[1, ])
}

# The math model rcalibration() evaluates once per iteration: the emulator's
# mean at the observed cells, at one theta. It was koh_emulate(), i.e.
# RobustGaSP::predict.ppgasp() with its predictive variances, per call (and
# on an emulated library one call per x setting, through griddy_map()):
# 2-10 ms an iteration (124-159 s for the ball drop's 58,000 iterations),
# several times the rest of RobustCalibration's iteration. The mean is
# linear in the correlations with the runs, so its weights are solved here,
# once (ppgasp_mean_function()).
koh_math_model <- function(emulator, observed) {
  mean_at <- koh_mean_function(emulator)
  function(x, th) mean_at(th)[observed]
}

# The emulator's mean outputs (library layout) at one theta, as koh_emulate()
# gives them up to rounding.
koh_mean_function <- function(emulator) {
  gp <- emulator$design_gp
  if (is.null(gp)) {
    outputs <- ppgasp_outputs_function(emulator$gp, emulator$vary, emulator$constant)
    return(function(th) as.vector(outputs(matrix(th, 1L))))
  }
  outputs <- ppgasp_outputs_function(gp$fit, gp$vary, gp$constant)
  if (gp$mode == "theta") return(function(th) as.vector(outputs(gp_scale(gp, matrix(th, 1L)))))
  # joint (x, theta) -> the n_t outputs of a run: one row per wanted setting,
  # the library's layout being the settings' outputs in turn
  rows <- rep(1L, gp$n_x)
  function(th) {
    inputs <- cbind(gp$settings, matrix(th, 1L)[rows, , drop = FALSE])
    as.vector(t(outputs(gp_scale(gp, inputs))))
  }
}

# A function of scaled inputs z (rows) returning the outputs (a matrix, one
# row per row of z): the constant ones as they are, the varying ones the
# ppgasp fit's mean.
ppgasp_outputs_function <- function(fit, vary, constant) {
  if (is.null(fit) || !any(vary)) {
    return(function(z) matrix(constant, nrow(z), length(constant), byrow = TRUE))
  }
  mean_at <- ppgasp_mean_function(fit)
  function(z) {
    out <- matrix(constant, nrow(z), length(constant), byrow = TRUE)
    out[, vary] <- mean_at(z)
    out
  }
}

# The predictive mean of a RobustGaSP::ppgasp() fit at the rows of z, as
# pred_ppgasp() computes it, h(z) theta_hat + r(z)' R^-1 (Y - X theta_hat),
# with R^-1 (Y - X theta_hat) solved once: a call then costs a correlation
# row per input (tens of microseconds) instead of predict.ppgasp()'s
# milliseconds. Fits it does not cover (an isotropic or periodic kernel, a
# trend other than a constant) go through predict.ppgasp().
ppgasp_mean_function <- function(fit) {
  kernels <- fit@kernel_type
  constant_trend <- fit@zero_mean == "Yes" || (ncol(fit@X) == 1L && all(fit@X == 1))
  if (fit@isotropic || !all(kernels %in% c("matern_5_2", "matern_3_2", "pow_exp")) ||
      !constant_trend) {
    return(function(z) RobustGaSP::predict.ppgasp(fit, z)$mean)
  }
  mu <- if (fit@zero_mean == "Yes") numeric(ncol(fit@output)) else fit@theta_hat[1, ]
  residual <- fit@output - rep(mu, each = nrow(fit@output))
  weights <- backsolve(t(fit@L), forwardsolve(fit@L, residual))
  input <- fit@input
  beta <- fit@beta_hat
  alpha <- rep_len(fit@alpha, ncol(input))
  kernels <- rep_len(kernels, ncol(input))
  function(z) {
    r <- 1
    for (j in seq_len(ncol(input))) {
      d <- beta[j] * abs(outer(z[, j], input[, j], "-"))
      r <- r * switch(kernels[j],
                      matern_5_2 = (1 + sqrt(5) * d + 5 / 3 * d^2) * exp(-sqrt(5) * d),
                      matern_3_2 = (1 + sqrt(3) * d) * exp(-sqrt(3) * d),
                      pow_exp = exp(-d^alpha[j]))
    }
    r %*% weights + rep(mu, each = nrow(z))
  }
}

# The field as rcalibration() takes it: `values`, one per observed cell, or
# with replicates a matrix of a row per observed cell (which it reduces to
# the cells' means and their pure error); and `y`, each cell's measurement
# or replicates' mean in the library's layout (NA where not measured). It
# also takes unequal replicates as a list, but then drops their pure error
# (RobustCalibration 0.5.6 squares the sum of the deviations from the mean,
# which is zero), so those are refused.
koh_observations <- function(library, field) {
  cells <- field_cells(library, field)
  layout <- field_layout(library, field)
  n_rep <- unique(layout$n_rep[layout$n_rep > 0L])
  if (length(n_rep) > 1L) {
    griddy_abort("koh_calibrate() takes replicated measurements only when every measured ",
                 "cell has the same number (RobustCalibration drops the pure error of unequal ",
                 "ones); `field` has ", paste(sort(n_rep), collapse = ", "), " per cell. ",
                 "calibrate() takes them.", class = "unsupported")
  }
  observed <- which(layout$n_rep > 0L)
  if (n_rep == 1L) return(list(y = layout$y, values = layout$y[observed]))
  keep <- !is.na(cells$value)
  by_cell <- split(cells$value[keep], factor(cells$cell[keep], levels = observed))
  list(y = layout$y, values = matrix(unlist(by_cell, use.names = FALSE), ncol = n_rep,
                                     byrow = TRUE))
}

# Emulator mean at the rows of th: one row per parameter set.
koh_emulate <- function(emulator, th) {
  if (!is.null(emulator$design_gp)) return(emulated_library_mean(emulator$design_gp, th))
  out <- matrix(emulator$constant, nrow(th), length(emulator$constant), byrow = TRUE)
  if (any(emulator$vary)) {
    pred <- RobustGaSP::predict.ppgasp(emulator$gp, th)$mean
    out[, emulator$vary] <- matrix(pred, nrow(th))
  }
  out
}

koh_quietly <- function(quiet, expr) {
  if (!quiet) return(expr)
  out <- NULL
  utils::capture.output(out <- expr)
  out
}

#' Summarise a Kennedy-O'Hagan baseline fit
#'
#' @param object A `griddy_koh` fit from [koh_calibrate()].
#' @param x A `griddy_koh_summary`.
#' @param level Credible level of the equal-tailed interval.
#' @param digits Significant digits to print (per parameter, as in
#'   [summary()][summary.griddy_fit]).
#' @param width Width of the printed lines.
#' @param ... Unused.
#' @return A data.frame (class `griddy_koh_summary`) with one row per
#'   parameter: `parameter`, `estimate` and `estimate_type` (the mean, or the
#'   median where the mean lies outside the interval, as in
#'   [summary()][summary.griddy_fit]), `mean`, `median`, `lower`, `upper`, and the
#'   rank-normalised `ess_bulk`, `ess_tail`, `rhat` (split chain) and `mcse`
#'   of Vehtari et al. (2021), as in [summary()][summary.griddy_fit], so the
#'   two methods' effective sample sizes compare like for like.
#' @examplesIf requireNamespace("RobustCalibration", quietly = TRUE)
#' f <- piston_field_data(15, seed = 1)
#' lib <- piston_library(4, locations = attr(f, "locations"))
#' koh <- koh_calibrate(lib, f, n_iter = 1500, burn_in = 500, tune_iter = 300,
#'                      seed = 1)
#' summary(koh)
#' @export
summary.griddy_koh <- function(object, level = 0.95, ...) {
  assert_level(level)
  draws <- koh_draws(object)
  structure(draws_summary(draws, rep(1L, nrow(draws)), level, type = 7),
            class = c("griddy_koh_summary", "data.frame"), level = level)
}

#' @rdname summary.griddy_koh
#' @export
print.griddy_koh_summary <- function(x, digits = 4, width = getOption("width"), ...) {
  cat_wrapped(paste0("Kennedy-O'Hagan baseline, ", 100 * attr(x, "level"),
                     "% equal-tailed intervals"), width)
  print_summary_table(x, digits, width, attr(x, "level"))
  invisible(x)
}

#' @export
`[.griddy_koh_summary` <- function(x, ...) keep_level(NextMethod(), x)

#' @export
print.griddy_koh <- function(x, digits = 4, ...) {
  cli::cat_line("<griddy_koh> Kennedy-O'Hagan calibration (RobustCalibration), ",
                x$discrepancy, " discrepancy")
  cli::cat_line("  emulator: ppgasp on ", x$n_runs, " runs; ", nrow(x$draws),
                " kept draws of ", x$control$n_iter)
  cli::cat_line("  acceptance: theta ", format(x$acceptance[["theta"]], digits = 2),
                ", kernel ", format(x$acceptance[["kernel"]], digits = 2))
  cli::cat_line("  runtime (s): ", paste(names(x$runtime), format(x$runtime, digits = 3),
                                         sep = " ", collapse = ", "))
  invisible(x)
}

#' Calibrated simulator output of a Kennedy-O'Hagan baseline fit
#'
#' The emulator's mean output at posterior draws of \eqn{\theta}, without the
#' discrepancy: the counterpart of the `mean`, `lower` and `upper` columns of
#' [predict.griddy_fit()], for a posterior predictive check.
#'
#' @param object A `griddy_koh` fit from [koh_calibrate()].
#' @param level Credible level of the band.
#' @param ndraws Number of draws (evenly spaced over the chain) to evaluate.
#' @param ... Unused.
#' @return A data.frame with one row per observation: its inputs, `observed`,
#'   and the emulated output's posterior `mean`, `lower` and `upper`.
#' @examplesIf requireNamespace("RobustCalibration", quietly = TRUE)
#' f <- piston_field_data(15, seed = 1)
#' lib <- piston_library(4, locations = attr(f, "locations"))
#' koh <- koh_calibrate(lib, f, n_iter = 1500, burn_in = 500, tune_iter = 300,
#'                      seed = 1)
#' head(predict(koh, ndraws = 200))
#' @export
predict.griddy_koh <- function(object, level = 0.95, ndraws = 1000, ...) {
  assert_level(level)
  ndraws <- assert_count(ndraws, "ndraws")
  pick <- unique(round(seq(1, nrow(object$draws), length.out = min(ndraws, nrow(object$draws)))))
  th <- as.matrix(object$draws[pick, object$parameters, drop = FALSE])
  out <- koh_emulate(object$emulator, th)
  probs <- c((1 - level) / 2, 1 - (1 - level) / 2)
  bounds <- apply(out, 2, stats::quantile, probs = probs, names = FALSE)
  data.frame(object$design, observed = object$y_field, mean = colMeans(out),
             lower = bounds[1, ], upper = bounds[2, ])
}
