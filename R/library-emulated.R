#' A library emulated from any design of simulation runs
#'
#' Builds a library at the control settings you want (usually the field's)
#' from simulation runs made wherever they were: a Latin hypercube over
#' \eqn{(x, \theta)} jointly (the Los Alamos `simobs` and Kennedy-O'Hagan
#' layout), an incomplete design, a few tens of runs, settings the field
#' lacks or runs at none of the wanted settings. It is the [sim_library()]
#' family's member for such designs; [read_calibration_inputs()] builds one
#' from the thesis's three files when the runs do not already form a
#' library.
#'
#' **The emulator** is one Gaussian process, RobustGaSP's
#' [ppgasp()][RobustGaSP::ppgasp] (no nugget unless the runs need one),
#' chosen by measurement (`bench/design-emulation.R`). When every
#' \eqn{\theta} of the design was run at every wanted setting it maps
#' \eqn{\theta} to all of a run's outputs at those settings (the thesis's ch.
#' 3 surrogate; runs at other settings are then not used); otherwise it maps
#' \eqn{(x, \theta)}, scaled to \[0, 1\], to the `n_t` outputs of a run, so
#' every run trains it.
#'
#' **The library** holds `n_runs` values of \eqn{\theta}, a Latin hypercube
#' (R's random stream) over the design's \eqn{\theta} range, each predicted
#' at every wanted setting.
#'
#' **Its error enters the likelihood.** A predicted run carries the
#' emulator's error \eqn{\delta \sim N(0, \kappa V)}. \eqn{V} is the second
#' moment of the design's leave-one-out residuals, each standardised by the
#' GP's own leave-one-out sd (so that the few runs at the design's edges,
#' where leaving one out extrapolates, do not set its shape). In the
#' \eqn{\theta} form it is taken over all outputs; in the joint form
#' \eqn{V = (S^{1/2} K_x S^{1/2}) \otimes V_t}: \eqn{V_t} the residuals'
#' second moment over t, \eqn{K_x} the GP's correlation between the wanted
#' settings and \eqn{S} each setting's mean predictive variance over the
#' library relative to their mean, so that a misprediction at one
#' \eqn{\theta}, shared by nearby settings, is not averaged away by them.
#' \eqn{\kappa} is the GP's predictive variance (mean over the settings)
#' over its mean leave-one-out variance on the design, averaged over the
#' posterior without the error: one value for every run. A run-dependent
#' \eqn{\kappa_i}, which rises towards the design's edges, would pull the
#' posterior there whenever the data sit further from every run than the
#' noise and the error allow: a Gaussian's density rises with its variance
#' while the variance is below the squared misfit. The error enters as in
#' [refine()]: the covariance \eqn{\tau^{-1} R + \kappa V}, with the
#' posterior mean of \eqn{1/\tau} under the calibration's prior as the
#' plug-in for \eqn{1/\tau}, found by a short fixed point for the field data
#' at hand. When the leave-one-out error near the posterior's mode exceeds
#' the noise sd (the replicates' pure error when the field data have
#' replicates; otherwise the smaller of the plug-in and the best run's
#' misfit per data point, which the emulator's error cannot inflate), the
#' intervals rest on the error model, an estimate, and a warning of class
#' `griddy_warning_emulation` says so. With replicates, data that no run
#' fits even with the error allowed for (an F test against the pure error)
#' are said in a warning of class `griddy_warning_lack_of_fit`. [refine()]
#' without a simulator predicts its new runs with this library's emulator.
#' A library that would not fit in the available memory is refused before
#' it is built (error class `griddy_error_memory`). Settings further than
#' 5% of the design's width outside its range of x, where the emulator
#' extrapolates, are named in a warning of class
#' `griddy_warning_extrapolation` (also `griddy_warning_emulation`).
#'
#' @param theta A data.frame, or a numeric matrix with column names, of the
#'   design runs' parameter values, one row per run.
#' @param y A numeric matrix of the runs' outputs, one row of `n_t` outputs
#'   per run (at that run's `x`).
#' @param x `NULL` (no control variables), or a data.frame (or named matrix,
#'   or numeric vector) of each run's control settings, one row per run.
#' @param t The `n_t` output coordinates, strictly increasing; `NULL` gives
#'   `1:n_t`.
#' @param settings The control settings of the library to build, one row
#'   each, with `x`'s columns; `NULL` takes the distinct settings of `x`.
#'   Must be `NULL` when `x` is.
#' @param n_runs The number of \eqn{\theta} values in the library.
#' @param t_out `NULL` (the library's outputs are at `t`), or the output
#'   coordinates of the library to build when they are not the runs' (e.g.
#'   the field's heights between the simulator's): each run's outputs are
#'   first interpolated along `t` to `t_out` by a cubic spline
#'   ([stats::splinefun()], `"fmm"`), within `t`'s range. The interpolation
#'   error, estimated by leaving each interior coordinate of `t` out, is kept
#'   as `interpolation$loo_rms` and printed; unlike the emulator's it is not
#'   in the likelihood, so `t` should be dense enough for it to be small
#'   against the noise. [read_calibration_inputs()] passes its `t_field`
#'   this way.
#' @param seed `NULL`, or a seed for this call only; either way the library
#'   is reproducible with [set.seed()].
#' @return An object of class `emulated_library`, a library usable wherever
#'   one is ([calibrate()], [posterior_exact()], [refine()],
#'   [koh_calibrate()]): a list with `theta`, `y` (predicted outputs, blocks
#'   by setting), `x` (the settings), `t`, `rel_var` (each run's
#'   \eqn{\kappa_i}, before it is averaged),
#'   `error` (the error model: `U`, `lambda`), `emulator` (the fitted GP and
#'   its leave-one-out residuals), `design` (the runs, their outputs at the
#'   library's `t`), `loo_rms`, the root mean square leave-one-out error over
#'   the design's outputs, and `interpolation` (`NULL`, or with `t_out` the
#'   runs' own coordinates `t` and the interpolation error `loo_rms`).
#' @seealso [sim_library()], [read_calibration_inputs()], [refine()]
#' @examplesIf requireNamespace("RobustGaSP", quietly = TRUE)
#' set.seed(1)
#' design <- data.frame(x = runif(30), k = runif(30, 1, 3))
#' t <- seq(0, 1, length.out = 5)
#' y <- t(apply(design, 1, function(r) sin(r[["k"]] * t + r[["x"]])))
#' lib <- emulated_library(design["k"], y, x = design["x"], t = t,
#'                         settings = data.frame(x = c(0.25, 0.75)),
#'                         n_runs = 500, seed = 1)
#' lib
#' @export
emulated_library <- function(theta, y, x = NULL, t = NULL, settings = NULL, n_runs = 10000,
                             seed = NULL, t_out = NULL) {
  theta <- as_theta_matrix(theta)
  y <- as_numeric_matrix(y, "y")
  if (nrow(y) != nrow(theta)) {
    griddy_abort("`y` must have one row per run: `theta` has ", nrow(theta), " rows but `y` ",
                 "has ", nrow(y), ".")
  }
  assert_finite(theta, "theta")
  assert_finite(y, "y")
  x <- design_x(x, nrow(theta))
  settings <- if (is.null(settings)) {
    if (is.null(x)) NULL else unique(x)
  } else {
    if (is.null(x)) griddy_abort("`settings` needs the runs' `x`.")
    as_settings(settings, "settings")
  }
  if (!is.null(x) && !setequal(names(settings), names(x))) {
    griddy_abort("`settings` must have `x`'s columns ", show_some(names(x)), "; received ",
                 show_some(names(settings)), ".")
  }
  if (!is.null(x)) {
    settings <- settings[names(x)]
    warn_extrapolation(settings, x)
  }
  t <- as_coordinates(t, ncol(y), "t", "outputs per run (columns of `y`)")
  t_out <- assert_output_coordinates(t_out, "t_out")
  interpolation <- NULL
  if (!is.null(t_out)) {
    y <- interpolate_outputs(y, t, t_out, "t_out")
    interpolation <- list(t = t, loo_rms = attr(y, "loo_rms"))
    attr(y, "loo_rms") <- NULL
    t <- t_out
  }
  n_runs <- assert_count(n_runs, "n_runs", min = 2L)
  assert_emulated_size(n_runs, ncol(theta), if (is.null(settings)) 1L else nrow(settings),
                       length(t))
  seed <- assert_seed(seed)
  library <- with_seed(seed, build_emulated_library(theta, y, x, t, settings, n_runs))
  library$interpolation <- interpolation
  library
}

# Settings beyond the design's range of x (by more than 5% of its width) are
# extrapolated: the GP reverts to its mean there and its error model,
# estimated by leaving design runs out, does not see it (x = 5 for a design
# over [0, 1]: an RMS error of 1.34 on outputs in [-1, 1]). Warn, naming
# each column, its furthest setting and how far out it lies.
warn_extrapolation <- function(settings, x) {
  far <- unlist(lapply(names(x), function(nm) {
    lo <- min(x[[nm]])
    hi <- max(x[[nm]])
    v <- settings[[nm]]
    beyond <- pmax(lo - v, v - hi, 0)
    slack <- max(0.05 * (hi - lo), 1e-8 * max(1, abs(lo), abs(hi)))
    if (all(beyond <= slack)) return(NULL)
    k <- which.max(beyond)
    paste0(nm, " = ", format(v[k], digits = 4), " (", sum(beyond > slack), " setting(s); ",
           format(beyond[k], digits = 3), " beyond the design's [", format(lo, digits = 4),
           ", ", format(hi, digits = 4), "]",
           if (hi > lo) paste0(", ", format(beyond[k] / (hi - lo), digits = 3),
                               " times its width"), ")")
  }))
  if (length(far) == 0L) return(invisible(FALSE))
  griddy_warn("The library's `settings` lie outside the design's range of x, where the ",
              "emulator extrapolates: its predictions revert to the Gaussian process's ",
              "mean and its error model, estimated inside the design, understates the ",
              "error. Furthest: ", paste(far, collapse = "; "), ". Run the simulator nearer ",
              "these settings, or calibrate only settings inside the design.",
              class = c("extrapolation", "emulation"))
  invisible(TRUE)
}

# The memory building the library takes at its peak, checked before any of
# it is allocated, in doubles per run: the predicted outputs (n_x n_t) and
# their variances (n_x), each held twice while the chunks are bound, a
# third copy of the outputs in the library, the Latin hypercube's draws,
# values and copies (4 p), and kappa with the chunks' row indices (2).
# Refused beyond the memory the system reports available, and beyond
# emulated_max_bytes.
emulated_max_bytes <- 64 * 2^30

assert_emulated_size <- function(n_runs, p, n_x, n_t) {
  bytes <- 8 * n_runs * (3 * n_x * n_t + 2 * n_x + 4 * p + 2)
  limit <- min(available_memory_bytes(), emulated_max_bytes)
  if (bytes > limit) {
    griddy_abort("An emulated library of ", format_count(n_runs), " runs x ",
                 format_count(n_x * n_t), " outputs would take about ", format_bytes(bytes),
                 ", more than the ", format_bytes(limit), " available; use a smaller `n_runs`.",
                 class = "memory")
  }
  invisible(bytes)
}

# The memory the system reports available (Linux's MemAvailable), Inf when
# it does not say.
available_memory_bytes <- function() {
  info <- tryCatch(readLines("/proc/meminfo", n = 5L, warn = FALSE), error = function(e) "",
                   warning = function(w) "")
  line <- grep("^MemAvailable:", info, value = TRUE)
  if (length(line) != 1L) return(Inf)
  kb <- suppressWarnings(as.numeric(gsub("[^0-9]", "", line)))
  if (is.finite(kb) && kb > 0) kb * 1024 else Inf
}

# Each run's control settings: a data.frame with one row per run (rows may
# repeat), or NULL.
design_x <- function(x, n) {
  if (is.null(x)) return(NULL)
  if (is.numeric(x) && is.null(dim(x))) x <- data.frame(x = x)
  if (is.matrix(x) && is.null(colnames(x))) colnames(x) <- paste0("x", seq_len(ncol(x)))
  if (!is.data.frame(x) && !is.matrix(x)) {
    griddy_abort("`x` must be NULL or a data.frame of each run's settings; received ",
                 class(x)[1], ".")
  }
  x <- as.data.frame(as_numeric_matrix(as.data.frame(x), "x"))
  if (nrow(x) != n) {
    griddy_abort("`x` must have one row per run (", n, "); it has ", nrow(x), ".")
  }
  assert_finite(as.matrix(x), "x")
  x
}

build_emulated_library <- function(theta, y, x, t, settings, n_runs) {
  design <- list(theta = theta, y = y,
                 x = if (is.null(x)) matrix(0, nrow(theta), 0L) else as.matrix(x))
  assert_distinct_design(cbind(design$x, theta))
  set_mat <- if (is.null(settings)) matrix(0, 1L, 0L) else as.matrix(settings)
  gp <- design_gp(design, set_mat)
  box <- rbind(apply(theta, 2, min), apply(theta, 2, max))
  lib_theta <- latin_hypercube(n_runs, box, colnames(theta))
  pred <- design_gp_predict(gp, as.matrix(lib_theta))
  scale <- mean(gp$loo_var)
  kappa <- if (scale > 0) rowMeans(pred$var) / scale else rowMeans(pred$var) * 0
  dimnames(pred$mean) <- NULL
  structure(
    list(theta = lib_theta, y = pred$mean, x = settings, t = t, rel_var = kappa,
         error = design_error_model(gp, pred$var), emulator = gp,
         design = list(theta = as.data.frame(theta), x = x, y = y),
         loo_rms = sqrt(mean(gp$loo^2)), noise = NULL),
    class = "emulated_library"
  )
}

# What other files may read of an emulated library (its fields stay in
# this file): the number of design runs it was emulated from, and the
# emulator's leave-one-out error (RMS).
emulated_design_runs <- function(library) nrow(library$design$theta)
emulated_loo_rms <- function(library) library$loo_rms
# The design runs (theta, x, y at the library's t), for predict() at new settings.
emulated_design <- function(library) library$design

assert_distinct_design <- function(m) {
  key <- do.call(paste, c(lapply(seq_len(ncol(m)), function(j) sprintf("%.12g", m[, j])),
                          sep = "|"))
  dup <- which(duplicated(key))
  if (length(dup) > 0L) {
    griddy_abort("The design has duplicated (x, theta) runs: row(s) ", show_some(dup),
                 " repeat row(s) ", show_some(match(key[dup], key)), ".")
  }
}

#' @export
print.emulated_library <- function(x, ...) {
  gp <- x$emulator
  cli::cat_line("<emulated_library> ", lib_n_runs(x), " runs of ", ncol(x$theta),
                " parameter(s), predicted from ", nrow(x$design$theta), " design runs")
  cli::cat_line("  emulator: RobustGaSP ppgasp, ",
                if (gp$mode == "theta") "theta -> all outputs (complete design)" else
                  "(x, theta) -> outputs (joint design)")
  cli::cat_line("  leave-one-out error (RMS): ", format(x$loo_rms, digits = 3),
                " (against the noise: see ?emulated_library)")
  ranges <- vapply(x$theta, function(v) {
    paste0(format(min(v), digits = 4), " to ", format(max(v), digits = 4))
  }, "")
  cli::cat_line("  theta: ", paste0(names(ranges), " [", ranges, "]", collapse = ", "))
  cli::cat_line("  x:     ", if (is.null(x$x)) "one setting" else
    paste0(nrow(x$x), " setting(s) of ", paste(names(x$x), collapse = ", ")))
  cli::cat_line("  outputs: ", lib_n_out(x), " per run")
  if (!is.null(x$interpolation)) {
    cli::cat_line("  t:     the runs' ", length(x$interpolation$t), " outputs interpolated to ",
                  length(x$t), " coordinate(s), error (RMS, leave-one-out) ",
                  format(x$interpolation$loo_rms, digits = 3))
  }
  invisible(x)
}

# ---- the library interface (see library.R) ----------------------

#' @exportS3Method
lib_outputs.emulated_library <- function(library, rows = NULL) {
  if (is.null(rows)) return(library$y)
  library$y[lib_check_rows(library, rows), , drop = FALSE]
}

# C with the emulation error at the library's own plug-in noise variance
# and shared kappa for these field data (emulated_noise_var() in
# emulation.R), its extra log-determinant folded in; warns when the
# emulator is worse than the noise. Returned with the error's size
# (`emulation_error`) and the plug-in (`plug_in`), which travels into the
# problem's library (new_griddy_problem(), misfit_parts()).
#' @exportS3Method
lib_quad_forms.emulated_library <- function(library, y_field, setup) {
  fixed <- emulated_noise_var(library, y_field, setup)
  warn_design_emulation(fixed$ratio)
  warn_lack_of_fit(fixed$lack_of_fit)
  list(C = fixed$C, emulation_error = fixed$ratio,
       plug_in = list(y_field = y_field, noise_var = fixed$noise_var, kappa = fixed$kappa))
}

warn_design_emulation <- function(ratio) {
  if (is.null(ratio) || !is.finite(ratio) || ratio <= emulation_error_threshold) return()
  griddy_warn("The library was emulated from its design runs, whose emulator predicts ",
              "the runs near the posterior with a leave-one-out error ",
              format(ratio, digits = 2), " times the noise. The intervals account for it ",
              "through an estimate of that error and may be biased; add design runs there, ",
              "or refine() with the simulator.", class = "emulation")
}

#' @exportS3Method
lib_check_integrity.emulated_library <- function(library) {
  y <- library$y
  if (!is.matrix(y) || !is.double(y) || nrow(y) != nrow(library$theta) ||
      ncol(y) != lib_n_out(library) || length(library$rel_var) != nrow(y) ||
      !is.list(library$emulator)) {
    griddy_abort("The emulated_library has been edited: its runs, outputs and emulation ",
                 "error do not fit together; rebuild it with emulated_library().",
                 class = "shape")
  }
  check_library_parts(library, nrow(y), ncol(y), "emulated_library",
                      fix = "Rebuild it with emulated_library().")
  if (!all(is.finite(y)) || !all(is.finite(library$rel_var))) {
    griddy_abort("The emulated_library has been edited: its outputs are not all finite.",
                 class = "shape")
  }
  invisible(library)
}

# ---- for refine() and koh_calibrate() ------------------------------------------

# refine()'s emulator of a round on an emulated library: the library's own
# (see round_emulator()), over its whole range, with its leave-one-out
# residuals for emulation_error_ratio().
emulated_round_emulator <- function(library) {
  list(method = "emulated_library", library = library,
       refine_region = library_box(library),
       loo = library$emulator$loo, loo_theta = library$emulator$loo_theta)
}

# New runs predicted by the library's emulator, with their kappa and the
# library's error model at plug-in noise variance s2.
emulated_library_batch <- function(library, theta_new, s2) {
  gp <- library$emulator
  pred <- design_gp_predict(gp, as.matrix(theta_new)[, gp$theta_names, drop = FALSE])
  scale <- mean(gp$loo_var)
  err <- library$error
  if (!is.null(err)) err$noise_var <- s2
  list(y = unname(pred$mean), rel_var = if (scale > 0) rowMeans(pred$var) / scale else
         rowMeans(pred$var) * 0, error = err)
}

# The emulator's mean outputs (library layout) at the rows of th.
emulated_library_mean <- function(gp, th) {
  th <- matrix(th, ncol = length(gp$theta_names), dimnames = list(NULL, gp$theta_names))
  design_gp_predict(gp, th)$mean
}

# ---- what refine() reads (see library.R) -----------------------------

#' @exportS3Method
lib_predicted.emulated_library <- function(library) rep(TRUE, lib_n_runs(library))

#' @exportS3Method
lib_simulated.emulated_library <- function(library) NULL

#' @exportS3Method
lib_noise_var.emulated_library <- function(library) {
  if (is.null(library$noise)) NA_real_ else library$noise$noise_var
}

# The shared kappa stays what the library found for these data (see
# emulation.R): only the noise scale is restated.
#' @exportS3Method
lib_with_noise_var.emulated_library <- function(library, noise_var, y_field) {
  kappa <- library$noise$kappa
  if (is.null(kappa)) kappa <- mean(library$rel_var)
  library$noise <- list(y_field = y_field, noise_var = noise_var, kappa = kappa)
  library
}

# The error model at the library's noise plug-in and its shared kappa, for
# every run (see run_errors()); NULL before the library has met field data.
#' @exportS3Method
lib_prediction_errors.emulated_library <- function(library) {
  if (is.null(library$error) || is.null(library$noise)) return(NULL)
  err <- library$error
  err$noise_var <- library$noise$noise_var
  list(n_base = lib_n_runs(library), base = list(error = err, kappa = library$noise$kappa),
       round = integer(), kappa = numeric(), errors = list(), replaced = integer())
}

#' @exportS3Method
lib_with_plug_in.emulated_library <- function(library, plug_in) {
  if (!is.null(plug_in)) library$noise <- plug_in
  library
}

#' @exportS3Method
lib_design_emulator.emulated_library <- function(library) library$emulator

# ---- an emulated library's own plug-in ----------------------------------------------

# The shared kappa of an emulated library's runs (see the top of emulation.R):
# the mean of kappa_i under the posterior over runs `p`.
emulated_kappa <- function(library, p) {
  sum(p * library$rel_var) / sum(p)
}

# The forms of an emulated library's runs at plug-in noise variance s2 and
# shared kappa: list(C, extra_logdet) (misfit_parts()).
emulated_library_forms <- function(library, y_field, setup, s2, kappa) {
  if (is.null(library$error)) return(list(C = plain_quad_forms(library$y, y_field, setup)))
  err <- library$error
  err$noise_var <- s2
  em <- emulated_quad_forms(library$y, y_field, setup, err, rep(kappa, nrow(library$y)),
                            lib_n_x(library), lib_n_t(library))
  list(C = em$C, extra_logdet = em$logdet)
}

# The noise variance and the shared kappa of an emulated library for these
# field data: kappa the posterior mean of kappa_i without the error, and the
# noise variance by a fixed point from the best run's misfit per data point,
# a few times the posterior mean of 1/tau (posterior_noise_var(), under the
# problem's prior setup$fold_prior, the runs equally weighted). A value restated by refine() for
# these field data is used as it is. Returns list(C (extra_logdet folded),
# noise_var, kappa, ratio = the leave-one-out error near the mode over the
# noise sd, emulation_error_ratio()'s measure).
emulated_noise_var <- function(library, y_field, setup, times = 6L) {
  prior <- setup$fold_prior
  if (is.null(prior)) prior <- thesis_prior()
  n <- sum(setup$group_sizes)
  posterior <- function(forms) {
    forms <- misfit_parts(forms)
    problem <- new_griddy_problem(library, y_field, prior, rep(-log(nrow(forms$C)), nrow(forms$C)),
                                  setup, C = fold_extra_logdet(forms, prior, n))
    post <- grid_posterior(problem)
    list(problem = problem, joint = post$joint, p = post$run, best = min(forms$C))
  }
  result <- function(state) {
    mode <- as.matrix(library$theta)[which.max(state$p), ]
    s2 <- state$problem$library$noise$noise_var
    list(C = state$problem$C, noise_var = s2, kappa = state$problem$library$noise$kappa,
         ratio = loo_error_near(library$emulator, mode,
                                reference_noise_var(setup, s2, state$problem$C,
                                                    roughness_noise_var(state))),
         lack_of_fit = lack_of_fit(setup, state$best))
  }
  stored <- library$noise
  if (!is.null(stored) && identical(stored$y_field, y_field)) {
    return(result(posterior(emulated_library_forms(library, y_field, setup,
                                                   stored$noise_var, stored$kappa))))
  }
  C0 <- plain_quad_forms(library$y, y_field, setup)
  s2 <- rep(max(min(C0) / n, 1e-300), length(setup$group_sizes))
  # kappa where the data put the runs before the error has a say: under the
  # posterior with the error, kappa would follow the mass the error pulls
  kappa <- emulated_kappa(library, posterior(C0)$p)
  for (i in seq_len(times)) {
    library$noise <- list(y_field = y_field, noise_var = s2, kappa = kappa)
    state <- posterior(emulated_library_forms(library, y_field, setup, s2, kappa))
    state$problem$library <- library
    s2_new <- pmax(posterior_noise_var(state), 1e-300)
    done <- all(abs(s2_new - s2) <= 0.01 * s2)
    s2 <- s2_new
    if (done) break
  }
  library$noise <- list(y_field = y_field, noise_var = s2, kappa = kappa)
  state <- posterior(emulated_library_forms(library, y_field, setup, s2, kappa))
  state$problem$library <- library
  result(state)
}
