# Issue 34, item 2: honest bands, measured. Does predict(fit, newdata,
# simulator = ) cover measurements at settings where no run was made?
# Two systems griddy has not seen with a simulator, each with a gap and
# without; calibrate on some x settings, predict held-out ones inside the
# calibrated range (interpolation) and outside it (extrapolation), and count
# how often the 95% band for a new measurement (pred_lower, pred_upper)
# holds a held-out measurement (fresh noise, the same sd as the field's),
# and the band's width inside against outside.
#
# Cooling: a cup cooling in still air, x = the ambient temperature Ta (deg C),
#   outputs at t = 1, 2, ..., 10 min. Simulator (Newton's law):
#   T(t) = Ta + (T0 - Ta) exp(-h t), theta = (h, T0) on a 61 x 61 grid.
#   Reality with a gap: natural convection, whose rate grows with the
#   temperature difference, dD/dt = -k D^(5/4) (D = T - Ta), so
#   D(t) = (D0^(-1/4) + k t / 4)^(-4), with k = 0.12 / 60^(1/4) and
#   T0 = 90; without a gap: Newton's law at h = 0.12, T0 = 90.
#   Noise sd 0.3 deg C. Calibrated at Ta = 10, 14, ..., 30; held out inside
#   at 12, 20, 28, outside at 0, 5, 35, 40. Knowledge: delta is zero at
#   t = 0 (both laws start at T0) at every Ta (rows at Ta = 0, 10, ..., 40).
# Beam: a cantilever of length 1 m under a tip load x = P (kN), deflection
#   at t = 0.1, 0.2, ..., 1 m along it. Simulator (linear elasticity with a
#   compliant root): w = P t^2 (3 - t) / (6 EI) + c P t,
#   theta = (EI, c) on a 61 x 61 grid.
#   Reality with a gap: the material softens, w_real = w (1 + (P / 12)^2);
#   without a gap: the simulator at EI = 20, c = 0.004. Noise sd 0.002 m.
#   Calibrated at P = 1, 2, ..., 6; held out inside at 1.5, 3.5, 5.5,
#   outside at 0.5, 7, 8. Knowledge: delta is zero and flat at P = 0 (no
#   load, no deflection, and the first response is linear), a row per t.
#
# Arms, with a gap: the orthogonal default gp_discrepancy(), orthogonal =
# FALSE, the knowledge (gp_discrepancy(zero_at =, flat_at =)), and no
# discrepancy (to show what a band without one does); without a gap: no
# discrepancy, and the default discrepancy. N_TRIALS (default 15) noise seeds
# per arm; each fit is calibrate() (3,000 iterations, 500 burn-in, seed =
# the trial's), predicted with predict(fit, newdata, simulator =, seed =).
#
# Run from the package root: Rscript data-raw/prediction-study.R
# (~5 min on a loaded 2-core machine). Writes inst/extdata/prediction_study.csv.gz
# (one row per trial, held-out setting and t).
pkgload::load_all(".", quiet = TRUE)
n_trials <- as.integer(Sys.getenv("N_TRIALS", "15"))

cooling <- local({
  t <- 1:10
  sim <- function(theta, x) {
    y <- t(mapply(function(h, T0) unlist(lapply(x$Ta, function(a) a + (T0 - a) * exp(-h * t))),
                  theta$h, theta$T0))
    matrix(y, nrow(theta))
  }
  k <- 0.12 / 60^0.25
  real <- function(x, gap) {
    unlist(lapply(x$Ta, function(a) {
      D0 <- 90 - a
      if (gap) a + (D0^-0.25 + k * t / 4)^-4 else a + D0 * exp(-0.12 * t)
    }))
  }
  theta <- expand.grid(h = seq(0.08, 0.18, length.out = 61), T0 = seq(87, 93, length.out = 61))
  list(name = "cooling", t = t, sim = sim, real = real, theta = theta, noise_sd = 0.3,
       fit_x = data.frame(Ta = seq(10, 30, by = 4)),
       inside = data.frame(Ta = c(12, 20, 28)), outside = data.frame(Ta = c(0, 5, 35, 40)),
       zero_at = data.frame(Ta = seq(0, 40, by = 10), t = 0), flat_at = NULL)
})

beam <- local({
  t <- seq(0.1, 1, by = 0.1)
  sim <- function(theta, x) {
    y <- t(mapply(function(EI, c) unlist(lapply(x$P, function(P) P * t^2 * (3 - t) / (6 * EI) +
                                                     c * P * t)), theta$EI, theta$c))
    matrix(y, nrow(theta))
  }
  real <- function(x, gap) {
    w <- c(sim(data.frame(EI = 20, c = 0.004), x))
    if (gap) w * (1 + rep(x$P / 12, each = length(t))^2) else w
  }
  theta <- expand.grid(EI = seq(14, 26, length.out = 61), c = seq(0, 0.012, length.out = 61))
  list(name = "beam", t = t, sim = sim, real = real, theta = theta, noise_sd = 0.002,
       fit_x = data.frame(P = 1:6), inside = data.frame(P = c(1.5, 3.5, 5.5)),
       outside = data.frame(P = c(0.5, 7, 8)),
       zero_at = data.frame(P = 0, t = t), flat_at = data.frame(P = 0, t = t))
})

arms <- list(
  list(gap = TRUE, arm = "orthogonal (default)", disc = function(s) gp_discrepancy()),
  list(gap = TRUE, arm = "orthogonal = FALSE",
       disc = function(s) gp_discrepancy(orthogonal = FALSE)),
  list(gap = TRUE, arm = "knowledge",
       disc = function(s) gp_discrepancy(zero_at = s$zero_at, flat_at = s$flat_at)),
  list(gap = TRUE, arm = "no discrepancy", disc = function(s) NULL),
  list(gap = FALSE, arm = "no discrepancy", disc = function(s) NULL),
  list(gap = FALSE, arm = "orthogonal (default)", disc = function(s) gp_discrepancy()))

trial <- function(s, lib, arm, seed) {
  set.seed(seed)
  n_t <- length(s$t)
  y <- s$real(s$fit_x, arm$gap) + stats::rnorm(nrow(s$fit_x) * n_t, sd = s$noise_sd)
  field <- field_data(matrix(y, nrow(s$fit_x), byrow = TRUE), x = s$fit_x, t = s$t)
  warned <- character(0)
  t0 <- proc.time()[["elapsed"]]
  fit <- withCallingHandlers(
    calibrate(lib, field, discrepancy = arm$disc(s), n_iter = 3000, burn_in = 500, seed = seed),
    warning = function(w) {
      warned <<- c(warned, class(w)[1])
      invokeRestart("muffleWarning")
    })
  held <- rbind(s$inside, s$outside)
  p <- predict(fit, newdata = held, simulator = s$sim, seed = seed)
  secs <- proc.time()[["elapsed"]] - t0
  truth <- s$real(held, arm$gap)
  new_y <- truth + stats::rnorm(length(truth), sd = s$noise_sd)
  data.frame(system = s$name, gap = arm$gap, arm = arm$arm, seed = seed,
             x = p[[names(held)]], t = p$t,
             where = rep(c("inside", "outside"), c(nrow(s$inside), nrow(s$outside)) * n_t),
             truth = truth, measured = new_y, mean = p$mean,
             pred_lower = p$pred_lower, pred_upper = p$pred_upper,
             gap_warned = "griddy_warning_gap" %in% warned,
             resolution_warned = "griddy_warning_resolution" %in% warned,
             seconds = secs)
}

rows <- list()
for (s in list(cooling, beam)) {
  lib <- sim_library(s$theta, s$sim(s$theta, s$fit_x), x = s$fit_x, t = s$t)
  for (a in seq_along(arms)) {
    for (i in seq_len(n_trials)) {
      r <- trial(s, lib, arms[[a]], seed = 100L * a + i)
      rows[[length(rows) + 1L]] <- r
      message(sprintf("%s gap=%s %s seed %d: inside %.2f outside %.2f (%.1f s)", s$name,
                      arms[[a]]$gap, arms[[a]]$arm, r$seed[1],
                      mean(with(r[r$where == "inside", ], pred_lower <= measured &
                                  measured <= pred_upper)),
                      mean(with(r[r$where == "outside", ], pred_lower <= measured &
                                  measured <= pred_upper)), r$seconds[1]))
    }
  }
}
out <- do.call(rbind, rows)
num <- vapply(out, is.double, TRUE)
out[num] <- lapply(out[num], signif, digits = 5)
con <- gzfile("inst/extdata/prediction_study.csv.gz", "w")
utils::write.csv(out, con, row.names = FALSE)
close(con)

cover <- function(d) mean(d$pred_lower <= d$measured & d$measured <= d$pred_upper)
summ <- do.call(rbind, lapply(split(out, list(out$system, out$gap, out$arm), drop = TRUE),
                              function(d) {
  ins <- d[d$where == "inside", ]
  outs <- d[d$where == "outside", ]
  data.frame(system = d$system[1], gap = d$gap[1], arm = d$arm[1],
             cover_inside = cover(ins), cover_outside = cover(outs),
             width_inside = stats::median(ins$pred_upper - ins$pred_lower),
             width_outside = stats::median(outs$pred_upper - outs$pred_lower),
             seconds = stats::median(d$seconds))
}))
print(summ, row.names = FALSE, digits = 3)
