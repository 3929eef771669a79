# The "gp" library emulator (see refine-emulator.R): a parallel partial
# Gaussian process (RobustGaSP::ppgasp(), Gu & Berger 2016) from theta to all
# outputs at once, one set of range parameters shared by the outputs and a
# variance and mean for each. Fitted on at most `max_runs` runs nearest to the
# region (its cost grows with the cube of the runs), inputs scaled to [0, 1]
# over those runs. Outputs constant over them are not modelled but returned
# as they are (ppgasp refuses them).

gp_emulator <- function(library, base, theta, max_runs, starts = 2L) {
  require_package("RobustGaSP", "for the \"gp\" library emulator")
  u_all <- scale_theta(theta, base)
  rows <- runs_for_region(u_all, base$region$u, max_runs)
  u <- u_all[rows, , drop = FALSE]
  y <- lib_outputs(library, rows)
  # a parameter constant over the runs used carries no information to them
  x_lower <- apply(u, 2, min)
  x_span <- apply(u, 2, max) - x_lower
  inputs <- which(x_span > 0)
  if (length(rows) < length(inputs) + 3L) {
    griddy_abort("The \"gp\" emulator needs at least ", length(inputs) + 3L, " runs; the ",
                 "region has ", length(rows), ". Use a larger region or `max_runs`.",
                 class = "input")
  }
  vary <- apply(y, 2, function(v) max(v) - min(v) > 1e-12 * max(abs(v)))
  em <- c(base, list(rows = rows, u = u, y = y, x_lower = x_lower[inputs],
                     x_span = x_span[inputs], inputs = inputs, vary = vary))
  em$fit <- if (any(vary)) gp_fit(gp_inputs(em, u), y[, vary, drop = FALSE], starts)
  em$var_max <- gp_max_variance(em)
  em$d_nn <- median_nn_distance(u)
  em
}

# A dense region's GP on fewer runs, or NULL: when at least max_runs / 2
# runs lie inside the region, the GP on the max_runs %/% 4 of them
# runs_for_region() spreads over it, kept if its root-mean-square error on
# (up to 1000 of) the region's other runs is at most 1e-3 of their outputs'
# standard deviation -- those runs are simulated, so this is a held-out test,
# not an estimate. On bench/diagnose-gap-speed.R's two regions (367 and
# 16,258 runs inside) it was 2e-8 and 1.4e-7 of outputs of sd 1, fitted in
# 0.4 s instead of 6.5 and 11 s. Its range parameters are optimised from one
# start instead of ppgasp()'s two (the test judges the fit whatever the
# start; on that bench's regions the second start found the same optimum,
# and the one-start fit took 0.14-0.2 s instead of 0.28-0.43 s).
gp_emulator_dense <- function(library, base, theta, max_runs) {
  u_all <- scale_theta(theta, base)
  inside <- which(distance_to_box(u_all, base$region$u) == 0)
  n_small <- max_runs %/% 4L
  if (length(inside) < max_runs / 2 || n_small < ncol(theta) + 3L) return(NULL)
  em <- tryCatch(gp_emulator(library, base, theta, n_small, starts = 1L),
                 griddy_error = function(e) NULL)
  if (is.null(em)) return(NULL)
  held <- setdiff(inside, em$rows)
  held <- held[unique(round(seq(1, length(held), length.out = min(1000L, length(held)))))]
  y <- lib_outputs(library, held)
  err <- gp_predict(em, list(u = u_all[held, , drop = FALSE]))$outputs - y
  spread <- stats::sd(as.vector(y))
  if (is.finite(spread) && spread > 0 && sqrt(mean(err^2)) <= 1e-3 * spread) em
}

# ppgasp without a nugget (the runs are deterministic), and with an estimated
# one when the correlation matrix of close runs is too ill-conditioned to fit;
# its range parameters optimised from `starts` initial values (ppgasp's
# default is 2).
gp_fit <- function(x, y, starts = 2L) {
  fit <- function(nugget_est) {
    tryCatch({
      out <- NULL
      utils::capture.output(out <- RobustGaSP::ppgasp(design = x, response = y,
                                                       nugget.est = nugget_est,
                                                       num_initial_values = starts))
      if (all(is.finite(out@beta_hat)) && all(is.finite(out@sigma2_hat))) out
    }, error = function(e) NULL)
  }
  out <- fit(FALSE)
  if (is.null(out)) out <- fit(TRUE)
  if (is.null(out)) {
    griddy_abort("RobustGaSP::ppgasp() failed to fit the \"gp\" emulator on ", nrow(x),
                 " runs, with and without a nugget; try method = \"local\".",
                 class = "numeric")
  }
  out
}

# Scaled theta (library ranges) to the GP's [0, 1] inputs.
gp_inputs <- function(emulator, u) {
  u <- u[, emulator$inputs, drop = FALSE]
  (u - rep(emulator$x_lower, each = nrow(u))) / rep(emulator$x_span, each = nrow(u))
}

# Mean and predictive variance at scaled points u: list(mean = m x n_out,
# var = the predictive variance relative to an output's estimated variance,
# the same for every output since they share the correlation).
gp_mean_var <- function(emulator, u) {
  ppgasp_mean_var(emulator$fit, emulator$vary, emulator$y[1, ], gp_inputs(emulator, u))
}

# A ppgasp fit's predictive mean of every output at inputs z (outputs it does
# not model keep their `constant` value) and its predictive variance relative
# to an output's estimated variance (the same for every output, which share
# the correlation; NaN where ppgasp cannot give it).
ppgasp_mean_var <- function(fit, vary, constant, z) {
  out <- matrix(constant, nrow(z), length(constant), byrow = TRUE)
  if (is.null(fit)) return(list(mean = out, var = rep(0, nrow(z))))
  pred <- RobustGaSP::predict.ppgasp(fit, z)
  out[, vary] <- pred$mean
  list(mean = out, var = pred$sd[, 1]^2 / fit@sigma2_hat[1])
}

# The largest predictive variance in the region, the scale of rel_var:
# probed at a Halton set, the corners and the centre of the region.
gp_max_variance <- function(emulator) {
  box <- emulator$region$u
  probes <- rbind(halton_in_box(512L, box), box_corners(box))
  v <- gp_mean_var(emulator, probes)$var
  if (any(is.finite(v))) max(v[is.finite(v)]) else NA_real_
}

gp_predict <- function(emulator, pts) {
  pred <- gp_mean_var(emulator, pts$u)
  # a variance ppgasp cannot give (NaN, near-singular runs) counts as the
  # largest: unknown error is not small error
  v <- pred$var
  v[!is.finite(v)] <- Inf
  rel_var <- if (is.finite(emulator$var_max) && emulator$var_max > 0) {
    pmin(1, v / emulator$var_max)
  } else {
    rep(1, nrow(pts$u))
  }
  # at a run, the run itself (ppgasp reproduces it to rounding; with a nugget, not)
  near <- nearest_runs(pts$u, emulator$u, 1L)
  at_run <- near$dist[, 1] == 0
  pred$mean[at_run, ] <- emulator$y[near$idx[at_run, 1], ]
  rel_var[at_run] <- 0
  list(outputs = pred$mean, rel_var = rel_var)
}

# Leave-one-out residuals of the library's runs (see ppgasp_loo()).
gp_loo <- function(emulator) {
  loo <- ppgasp_loo(emulator$fit, emulator$vary, length(emulator$rows))
  list(rows = emulator$rows, residuals = loo$residuals)
}

# Leave-one-out residuals and predictive variances (relative to an output's
# estimated variance) of a ppgasp fit on n runs, in closed form for the
# fitted range parameters, the trend re-estimated without the run (Dubrule
# 1983): with R the runs' correlation and H the trend basis,
#   Q = R^-1 - R^-1 H (H' R^-1 H)^-1 H' R^-1,
#   residual_i = (Q y)_i / Q_ii,  variance_i = 1 / Q_ii.
# `vary` marks the outputs the fit models (NULL fit: none; residuals 0).
ppgasp_loo <- function(fit, vary, n) {
  res <- matrix(0, n, length(vary))
  if (is.null(fit)) return(list(residuals = res, var = rep(0, n)))
  r_inv <- chol2inv(t(fit@L))
  r_inv_h <- r_inv %*% fit@X
  q <- r_inv - r_inv_h %*% solve(crossprod(fit@X, r_inv_h), t(r_inv_h))
  res[, vary] <- (q %*% fit@output) / diag(q)
  list(residuals = res, var = 1 / diag(q))
}
