# A small system with a known gap, for the discrepancy's posterior, plot and
# prediction.

# A library eta = k a (1 + t) at amplitudes a = 1, 2, 3 and field data at
# k = 1 plus a bump of height `bump` at a = 3, t = 0.5 that no k imitates,
# with `reps` replicated experiments. `truth` is the field's mean.
bump_sys <- function(bump = 0.4, sd = 0.05, reps = 1, seed = 1, n_t = 21) {
  t <- seq(0, 1, length.out = n_t)
  x <- data.frame(amp = c(1, 2, 3))
  theta <- data.frame(k = seq(0.5, 1.5, by = 0.02))
  sim <- function(k) unlist(lapply(x$amp, function(a) k * a * (1 + t)))
  gap <- unlist(lapply(x$amp, function(a) bump * (a == 3) * exp(-((t - 0.5) / 0.12)^2)))
  set.seed(seed)
  truth <- sim(1) + gap
  y <- do.call(rbind, lapply(seq_len(reps), function(r) {
    matrix(truth + stats::rnorm(length(truth), sd = sd), nrow(x), n_t, byrow = TRUE)
  }))
  list(library = sim_library(theta, t(vapply(theta$k, sim, numeric(3 * n_t))), x = x, t = t),
       field = field_data(y, x = x[rep(1:3, reps), , drop = FALSE], t = t), gap = gap,
       truth = truth)
}

# The gap as the calibrated runs see it: the field's mean minus the
# simulator's posterior mean outputs (the bump, and what a k that the bump
# pulls off 1 misses besides).
seen_gap <- function(sys, fit) sys$truth - posterior_mean_outputs(fit)

# (A plain discrepancy: the tests of its posterior compare it with the whole
# gap, which an orthogonal one shares with k.)
bump_fit <- function(sys, ...) {
  suppressWarnings(
    calibrate(sys$library, sys$field, n_iter = 800, burn_in = 200, seed = 1,
              discrepancy = gp_discrepancy(orthogonal = FALSE), ...),
    classes = c("griddy_warning_resolution", "griddy_warning_gap"))
}

# A 2-parameter library eta = a l exp(-b t) on an n_grid x n_grid grid over
# loads l = 1, 2, 3 and n_t outputs; field data at `truth` plus
# `bump * gap(l, t)` plus noise of sd `sd`, with `reps` replicated
# experiments. Used by test-discrepancy.R (a sin-shaped gap, truth on a run)
# and test-discrepancy-evidence.R (a gap growing with load and t, truth
# between the runs).
load_decay_system <- function(gap, bump, n_grid, n_t, truth, sd = 0.05, seed = 3, reps = 1) {
  grid <- expand.grid(a = seq(1, 2, length.out = n_grid), b = seq(0, 1, length.out = n_grid))
  x <- data.frame(load = c(1, 2, 3))
  t <- seq(0, 1, length.out = n_t)
  sim <- function(a, b) unlist(lapply(x$load, function(l) a * l * exp(-b * t)))
  y <- t(mapply(sim, grid$a, grid$b))
  set.seed(seed)
  mu <- sim(truth[1], truth[2]) + bump * gap(rep(x$load, each = n_t), rep(t, nrow(x)))
  field <- do.call(rbind, lapply(seq_len(reps), function(r) {
    matrix(mu + stats::rnorm(length(mu), sd = sd), nrow(x), n_t, byrow = TRUE)
  }))
  list(library = sim_library(grid, y, x = x, t = t),
       field = field_data(field, x = x[rep(seq_len(nrow(x)), reps), , drop = FALSE], t = t),
       simulator = function(theta) t(mapply(sim, theta$a, theta$b)))
}

# toy_missing() with missing cells, a relative sd and two noise groups,
# calibrated with a discrepancy (`orthogonal` as gp_discrepancy() takes it):
# the toy, its sd and groups, and the fit.
missing_groups_fit <- function(orthogonal = NULL) {
  toy <- toy_missing()
  sd <- rep(c(0.5, 1, 2), each = 5)
  groups <- rep(c(1, 2, 2, 1, 2), 3)
  fit <- suppressWarnings(calibrate(
    toy$library, field_data(toy$y, x = toy$x, t = toy$t, sd = sd), rho_x = 0.5,
    rho_t = c(0, 0.6), n_iter = 100, burn_in = 10, seed = 1, noise_groups = groups,
    discrepancy = gp_discrepancy(ratio = c(0, 1, 10), length_x = 0.5, length_t = 0.3,
                                 orthogonal = orthogonal)))
  list(toy = toy, sd = sd, groups = groups, fit = fit)
}
