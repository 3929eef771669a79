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
#' **Its error enters the likelihood.** A predicted run \eqn{i} carries the
#' emulator's error \eqn{\delta_i \sim N(0, \kappa_i V)}: \eqn{\kappa_i} is
#' the GP's predictive variance at the run (mean over the settings) over its
#' mean leave-one-out variance on the design, and \eqn{V} the second moment
#' of the leave-one-out residuals. In the \eqn{\theta} form \eqn{V} is that
#' of the residuals over all outputs. In the joint form it is
#' \eqn{V = (S^{1/2} K_x S^{1/2}) \otimes V_t}: \eqn{V_t} the residuals'
#' second moment over t, \eqn{K_x} the GP's correlation between the wanted
#' settings and \eqn{S} each setting's mean predictive variance over the
#' library relative to their mean, so that a misprediction at one
#' \eqn{\theta}, shared by nearby settings, is not averaged away by them. It
#' enters as in [refine()]: the covariance \eqn{\tau^{-1} R + \kappa_i V}
#' with a plug-in noise variance for \eqn{1/\tau}, here found by the library
#' itself for the field data at hand, by a short fixed point (the best
#' run's misfit per point, then the posterior mean of \eqn{1/\tau}, a few
#' times). When the leave-one-out error near the posterior's mode exceeds
#' that noise (the ratio `refine()` reports as `emulation_error`), the
#' intervals rest on the error model, an estimate, and a warning of class
#' `griddy_warning_emulation` says so. [refine()] without a simulator
#' predicts its new runs with this library's emulator.
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
#' @param seed `NULL`, or a seed for this call only; either way the library
#'   is reproducible with [set.seed()].
#' @return An object of class `emulated_library`, a library usable wherever
#'   one is ([calibrate()], [posterior_exact()], [refine()],
#'   [koh_calibrate()]): a list with `theta`, `y` (predicted outputs, blocks
#'   by setting), `x` (the settings), `t`, `rel_var` (\eqn{\kappa_i}),
#'   `error` (the error model: `U`, `lambda`), `emulator` (the fitted GP and
#'   its leave-one-out residuals), `design` (the runs) and `loo_rms`, the
#'   root mean square leave-one-out error over the design's outputs.
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
                             seed = NULL) {
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
  if (!is.null(x)) settings <- settings[names(x)]
  t <- as_coordinates(t, ncol(y), "t", "outputs per run (columns of `y`)")
  n_runs <- assert_count(n_runs, "n_runs", min = 2L)
  seed <- assert_seed(seed)
  with_seed(seed, build_emulated_library(theta, y, x, t, settings, n_runs))
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

assert_distinct_design <- function(m) {
  key <- do.call(paste, c(lapply(seq_len(ncol(m)), function(j) sprintf("%.12g", m[, j])),
                          sep = "|"))
  dup <- which(duplicated(key))
  if (length(dup) > 0L) {
    griddy_abort("The design has duplicated (x, theta) runs: row(s) ", show_some(dup),
                 " repeat row(s) ", show_some(match(key[dup], key)), ".")
  }
}

# The error model over the library's outputs (see the documentation):
# list(U, lambda), noise_var set where the field data are known. In the
# joint form V = (S^1/2 K_x S^1/2) (x) V_t, whose eigenpairs are the
# products of its factors'.
design_error_model <- function(gp, var) {
  if (gp$mode == "theta") return(emulation_error_model(gp$loo, NA_real_))
  vt <- emulation_error_model(gp$loo, NA_real_)
  if (is.null(vt)) return(NULL)
  s <- colMeans(var)
  s <- if (mean(s) > 0) s / mean(s) else rep(1, length(s))
  kx <- eigen(sqrt(s) * t(sqrt(s) * design_gp_setting_cor(gp)), symmetric = TRUE)
  lambda <- outer(pmax(kx$values, 0), vt$lambda)
  order <- order(lambda, decreasing = TRUE)
  energy <- cumsum(lambda[order]) / sum(lambda)
  m <- min(which(energy >= 0.9999)[1], 50L, length(lambda))
  keep <- order[seq_len(m)]
  kx_j <- row(lambda)[keep]
  vt_j <- col(lambda)[keep]
  U <- vapply(seq_len(m), function(j) {
    kronecker(kx$vectors[, kx_j[j]], vt$U[, vt_j[j]])
  }, numeric(gp$n_x * gp$n_t))
  list(U = matrix(U, ncol = m), lambda = lambda[keep], noise_var = NA_real_)
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
  invisible(x)
}

# ---- the library interface (see library_interface.R) ----------------------

#' @exportS3Method
lib_outputs.emulated_library <- function(library, rows = NULL) {
  if (is.null(rows)) return(library$y)
  library$y[lib_check_rows(library, rows), , drop = FALSE]
}

# C with the emulation error at the library's own plug-in noise variance
# for these field data (see emulated_noise_var()), and attribute
# "extra_logdet"; warns when the emulator is worse than the noise.
#' @exportS3Method
lib_quad_forms.emulated_library <- function(library, y_field, setup) {
  fixed <- emulated_noise_var(library, y_field, setup)
  warn_design_emulation(fixed$ratio)
  structure(fixed$C, emulation_error = fixed$ratio)
}

# C of the library's runs at plug-in noise variance s2.
emulated_library_forms <- function(library, y_field, setup, s2) {
  if (is.null(library$error)) return(plain_quad_forms(library$y, y_field, setup))
  err <- library$error
  err$noise_var <- s2
  em <- emulated_quad_forms(library$y, y_field, setup, err, library$rel_var,
                            lib_n_x(library), lib_n_t(library))
  structure(em$C, extra_logdet = em$logdet)
}

# The noise variance that puts the emulation error on the scale of 1/tau:
# the smallest misfit per data point (the best run's), then, a few times,
# the posterior mean of 1/tau under the error model with the last value
# (tau's prior taken as Jeffreys', the runs and grid points uniform; the
# calibration's own prior is not known here). A value restated by refine()
# for these field data is used as it is. Returns list(C, noise_var, ratio =
# the leave-one-out error near the mode over the noise sd).
emulated_noise_var <- function(library, y_field, setup, times = 4L) {
  n <- sum(setup$group_sizes)  # every measurement
  stored <- library$noise
  if (!is.null(stored) && identical(stored$y_field, y_field)) {
    C <- emulated_library_forms(library, y_field, setup, stored$noise_var)
    return(list(C = C, noise_var = stored$noise_var,
                ratio = emulated_error_ratio(library, C, setup, stored$noise_var, n)))
  }
  C0 <- plain_quad_forms(library$y, y_field, setup)
  s2 <- max(min(C0) / n, 1e-300)
  C <- C0
  for (i in seq_len(times)) {
    C <- emulated_library_forms(library, y_field, setup, s2)
    w <- emulated_weights(C, setup, n)
    s2_new <- max(sum(w * C) / max(n - 2, 1), 1e-300)
    done <- abs(s2_new - s2) <= 0.01 * s2
    s2 <- s2_new
    if (done) break
  }
  C <- emulated_library_forms(library, y_field, setup, s2)
  list(C = C, noise_var = s2, ratio = emulated_error_ratio(library, C, setup, s2, n))
}

# Posterior weights over (run, grid point) for the fixed point: tau
# integrated out under Jeffreys' prior, the extra log-determinant included.
emulated_weights <- function(C, setup, n) {
  extra <- attr(C, "extra_logdet")
  if (is.null(extra)) extra <- 0
  lw <- -(n / 2) * log(pmax(C, 1e-300)) - extra / 2
  lw <- sweep(lw, 2, setup$logdet / 2, "-")
  w <- exp(lw - max(lw))
  w / sum(w)
}

# The leave-one-out error of the design runs nearest the posterior's most
# probable run (2p + 1 of them, in theta) over the noise sd: the ratio
# refine() reports as `emulation_error`.
emulated_error_ratio <- function(library, C, setup, s2, n) {
  w <- emulated_weights(C, setup, n)
  mode <- as.matrix(library$theta)[which.max(rowSums(w)), ]
  loo_error_near(library$emulator, mode, s2)
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

# ---- what refine() reads (see library_interface.R) -----------------------------

#' @exportS3Method
lib_predicted.emulated_library <- function(library) rep(TRUE, lib_n_runs(library))

#' @exportS3Method
lib_simulated.emulated_library <- function(library) NULL

#' @exportS3Method
lib_noise_var.emulated_library <- function(library) {
  if (is.null(library$noise)) NA_real_ else library$noise$noise_var
}

#' @exportS3Method
lib_with_noise_var.emulated_library <- function(library, noise_var, y_field) {
  library$noise <- list(y_field = y_field, noise_var = noise_var)
  library
}
