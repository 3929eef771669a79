# predict() at x settings the library does not hold (fit-predict-new.R).

# The simple machine (Brynjarsdottir and O'Hagan 2014): simulator theta x,
# reality theta x / (1 + x / 20), theta = 0.65, 11 settings on [0.2, 4].
machine <- function(sd = 0.01, step = 0.0025, gap = TRUE, seed = 1) {
  x <- data.frame(x = seq(0.2, 4, length.out = 11))
  theta <- data.frame(theta = seq(0.3, 1, by = step))
  set.seed(seed)
  real <- if (gap) 0.65 * x$x / (1 + x$x / 20) else 0.65 * x$x
  list(library = sim_library(theta, outer(theta$theta, x$x), x = x), x = x,
       field = field_data(matrix(real + stats::rnorm(11, sd = sd)), x = x),
       simulator = function(theta, x) outer(theta$theta, x$x))
}

machine_fit <- function(m, n_iter = 2000, ...) {
  suppressWarnings(calibrate(m$library, m$field, n_iter = n_iter, burn_in = 200, seed = 1, ...),
                   classes = c("griddy_warning_resolution", "griddy_warning_gap",
                               "griddy_warning_convergence", "griddy_warning_prior"))
}

# predict() beyond the measured settings, where a fit without a discrepancy
# says that its band assumes the simulator is right (tested on its own below)
extrapolate <- function(...) {
  suppressWarnings(predict(...), classes = "griddy_warning_extrapolation")
}

knowledge <- function() {
  gp_discrepancy(zero_at = data.frame(x = 0), flat_at = data.frame(x = 0))
}

test_that("at library settings the answer is today's, with or without a simulator", {
  m <- machine()
  fit <- machine_fit(m, discrepancy = knowledge())
  at <- m$x[c(3, 7), , drop = FALSE]
  today <- predict(fit, newdata = at, ndraws = 300, seed = 2)
  expect_identical(predict(fit, newdata = at, ndraws = 300, seed = 2, simulator = m$simulator),
                   today)
  # mixed with new settings, the library's rows are still today's
  mixed <- predict(fit, newdata = data.frame(x = c(at$x[1], 5, at$x[2])), ndraws = 300,
                   seed = 2, simulator = m$simulator)
  expect_equal(mixed$x, c(at$x[1], 5, at$x[2]))
  expect_equal(mixed[c(1, 3), ], today, ignore_attr = TRUE)
  expect_true(is.na(mixed$setting[2]))
  expect_true(is.na(mixed$observed[2]))
})

test_that("a linear simulator's prediction at a new setting is the closed-form Student t", {
  # y = theta x + e with a flat prior on theta and tau integrated out:
  # theta | y ~ t_{n-1}(theta_hat, s^2 / Sxx), so at x0 the simulator's mean
  # is x0 theta_hat and a new measurement is t_{n-1}(x0 theta_hat,
  # s^2 (1 + x0^2 / Sxx)).
  m <- machine(sd = 0.05, step = 0.0005, gap = FALSE)
  fit <- machine_fit(m, n_iter = 6000)
  y <- m$field$y[, 1]
  x <- m$x$x
  sxx <- sum(x^2)
  theta_hat <- sum(x * y) / sxx
  s <- sqrt(sum((y - theta_hat * x)^2) / (length(y) - 1))
  q <- stats::qt(0.975, length(y) - 1)
  x0 <- 6
  expect_warning(p <- predict(fit, newdata = data.frame(x = x0), ndraws = 6000, seed = 1,
                              simulator = m$simulator),
                 class = "griddy_warning_extrapolation")
  sd_mean <- x0 * s / sqrt(sxx)
  expect_equal(p$mean, x0 * theta_hat, tolerance = 0.15 * sd_mean / (x0 * theta_hat))
  half <- q * sd_mean
  expect_equal(c(p$lower, p$upper), x0 * theta_hat + c(-1, 1) * half,
               tolerance = 0.1 * half / (x0 * theta_hat))
  half_pred <- q * s * sqrt(1 + x0^2 / sxx)
  expect_equal(c(p$pred_lower, p$pred_upper), x0 * theta_hat + c(-1, 1) * half_pred,
               tolerance = 0.1 * half_pred / (x0 * theta_hat))
})

test_that("the discrepancy at a new cell on a library setting is the library cell's", {
  # the extended kernel's library block is the fit's, and a new cell where a
  # library cell is has that cell's row: delta's law there is the fit's, for
  # knowledge (K*) and for an orthogonal discrepancy (the simulator is
  # linear in theta, so the new cells' sensitivities are the fit's exactly)
  m <- machine()
  for (disc in list(knowledge(), gp_discrepancy(), gp_discrepancy(scaled = TRUE))) {
    fit <- machine_fit(m, discrepancy = disc)
    x_new <- m$x[c(4, 9), , drop = FALSE]
    kernels <- attr(fit$setup$discrepancy, "kernels")
    G <- attr(kernels, "sensitivity")
    near <- if (!is.null(G)) sensitivity_runs(fit$library, fit$draws$run, ncol(G))
    E <- if (!is.null(G)) new_sensitivity_rows(fit$library, G, near,
                                               m$simulator(lib_theta(fit$library)[near, ,
                                                           drop = FALSE], x_new))
    ext <- extended_kernels(fit$library, kernels, x_new, E)
    # (the fit's dense kernels: fit_kernels() gives NULL for a low-rank setup,
    # whose law reads the factors)
    expect_equal(lapply(ext, function(K) K[1:11, 1:11]),
                 discrepancy_kernels(fit$library, kernels), tolerance = 1e-10)
    all_draws <- seq_len(nrow(fit$draws))
    delta <- new_delta(fit, x_new, all_draws, integer(0), E)
    expect_equal(delta$mean, discrepancy_moments(fit)$mean[c(4, 9)], tolerance = 1e-6)
  }
})

test_that("several outputs per setting, replicates and correlated noise extend too", {
  sys <- bump_sys(reps = 2, n_t = 11)
  fit <- suppressWarnings(calibrate(sys$library, sys$field, rho_t = c(0, 0.5), n_iter = 600,
                                    burn_in = 100, seed = 1, discrepancy = gp_discrepancy()))
  t <- lib_t(sys$library)
  simulator <- function(theta, x) {
    t(vapply(theta$k, function(k) unlist(lapply(x$amp, function(a) k * a * (1 + t))),
             numeric(nrow(x) * length(t))))
  }
  x_new <- data.frame(amp = 2)
  G <- attr(attr(fit$setup$discrepancy, "kernels"), "sensitivity")
  near <- sensitivity_runs(fit$library, fit$draws$run, ncol(G))
  E <- new_sensitivity_rows(fit$library, G, near,
                            simulator(lib_theta(fit$library)[near, , drop = FALSE], x_new))
  delta <- new_delta(fit, x_new, seq_len(nrow(fit$draws)), integer(0), E)
  expect_equal(delta$mean, discrepancy_moments(fit)$mean[12:22], tolerance = 1e-6)
  p <- predict(fit, newdata = data.frame(amp = c(2.5, 6)), ndraws = 200, seed = 1,
               simulator = simulator)
  expect_equal(nrow(p), 22L)
  expect_equal(p$t, rep(t, 2))
  expect_true(all(is.finite(as.matrix(p[c("mean", "lower", "upper", "pred_lower",
                                           "pred_upper")]))))
  expect_true(all(p$lower < p$mean & p$mean < p$upper))
})

test_that("the discrepancy band widens outside the calibrated range", {
  m <- machine()
  inside <- c(1.5, 2.3, 3.1)
  outside <- c(5, 6)
  for (disc in list(knowledge(), gp_discrepancy())) {
    fit <- machine_fit(m, discrepancy = disc)
    p <- predict(fit, newdata = data.frame(x = c(inside, outside)), ndraws = 500, seed = 1,
                 simulator = m$simulator)
    width <- p$upper - p$lower
    pred_width <- p$pred_upper - p$pred_lower
    expect_gt(min(width[p$x %in% outside]), 3 * max(width[p$x %in% inside]))
    expect_gt(min(pred_width[p$x %in% outside]), 2 * max(pred_width[p$x %in% inside]))
  }
  # far away delta reverts to its prior, mean 0: the simulator's mean (an
  # orthogonal discrepancy keeps there the change of theta it left to theta)
  fit <- machine_fit(m, discrepancy = knowledge())
  far <- predict(fit, newdata = data.frame(x = 400), ndraws = 500, seed = 1,
                 simulator = m$simulator)
  alone <- predict(fit, newdata = data.frame(x = 400), ndraws = 500, seed = 1,
                   simulator = m$simulator, discrepancy = FALSE)
  expect_equal(far$mean, alone$mean, tolerance = 1e-6)
})

test_that("without a discrepancy, extrapolation is said to assume the simulator is right", {
  m <- machine(gap = FALSE)
  fit <- machine_fit(m, n_iter = 800)
  # inside the measured range (between settings): no warning
  expect_no_warning(predict(fit, newdata = data.frame(x = 1.1), ndraws = 200, seed = 1,
                            simulator = m$simulator))
  w <- expect_warning(predict(fit, newdata = data.frame(x = c(1.1, 5)), ndraws = 200, seed = 1,
                              simulator = m$simulator),
                      class = "griddy_warning_extrapolation")
  expect_match(conditionMessage(w), "x = 5,")
  expect_false(grepl("x = 1.1", conditionMessage(w), fixed = TRUE))
  expect_match(conditionMessage(w), "x from 0.2 to 4")
  # the measured range, not the library's: a library setting without field data is outside
  y <- m$field$y
  y[11, 1] <- NA
  fit_short <- suppressWarnings(calibrate(m$library, field_data(y, x = m$x), n_iter = 800,
                                          burn_in = 100, seed = 1))
  expect_warning(predict(fit_short, newdata = data.frame(x = 3.9), ndraws = 200, seed = 1,
                         simulator = m$simulator),
                 "x from 0.2 to 3.62", class = "griddy_warning_extrapolation")
  # a discrepancy fit's band widens there instead: no warning
  fit_d <- machine_fit(m, n_iter = 800, discrepancy = knowledge())
  expect_no_warning(predict(fit_d, newdata = data.frame(x = 5), ndraws = 200, seed = 1,
                            simulator = m$simulator))
})

test_that("only the runs carrying run_mass of the posterior are simulated", {
  m <- machine(sd = 0.05, step = 0.0005, gap = FALSE)
  fit <- machine_fit(m)
  seen <- new.env()
  counting <- function(theta, x) {
    seen$n <- c(seen$n, nrow(theta))
    outer(theta$theta, x$x)
  }
  extrapolate(fit, newdata = data.frame(x = 6), simulator = counting, run_mass = 0.9)
  freq <- sort(tabulate(fit$draws$run), decreasing = TRUE)
  expect_equal(sum(seen$n), which(cumsum(freq) >= 0.9 * sum(freq))[1])
  seen$n <- NULL
  extrapolate(fit, newdata = data.frame(x = 6), simulator = counting, run_mass = 1)
  expect_equal(sum(seen$n), sum(freq > 0))
})

test_that("new settings without a simulator, or with a broken one, are classed errors", {
  m <- machine()
  fit <- machine_fit(m)
  expect_error(predict(fit, newdata = data.frame(x = 6)),
               "pass `simulator = function\\(theta, x\\)`", class = "griddy_error_prediction")
  expect_error(predict(fit, newdata = data.frame(x = 6), simulator = "theta * x"),
               class = "griddy_error_input")
  expect_error(predict(fit, newdata = data.frame(x = c(5, 6)),
                       simulator = function(theta, x) outer(theta$theta, 1)),
               "expecting 2 outputs per run", class = "griddy_error_shape")
  expect_error(predict(fit, newdata = data.frame(x = 6),
                       simulator = function(theta, x) outer(theta$theta, x$x) / 0 - Inf),
               class = "griddy_error_simulator")
  expect_error(predict(fit, newdata = data.frame(x = 6), simulator = m$simulator,
                       run_mass = 0), class = "griddy_error_input")
  expect_error(predict(fit, newdata = data.frame(x = NA_real_), simulator = m$simulator),
               class = "griddy_error_input")
  grouped <- suppressWarnings(calibrate(m$library, m$field, n_iter = 300, burn_in = 50,
                                        seed = 1, noise_groups = rep(c("a", "b"), c(5, 6))))
  expect_error(predict(grouped, newdata = data.frame(x = 6), simulator = m$simulator),
               class = "griddy_error_unsupported")
})

test_that("an HDF5 library predicts at new settings as the same library in memory", {
  skip_if_not_installed("hdf5r")
  m <- machine()
  file <- withr::local_tempfile(fileext = ".h5")
  on_disk <- write_library(m$library, file)
  fits <- lapply(list(m$library, on_disk), function(lib) {
    suppressWarnings(calibrate(lib, m$field, n_iter = 600, burn_in = 100, seed = 1,
                               discrepancy = knowledge()))
  })
  p <- lapply(fits, predict, newdata = data.frame(x = c(3, 6)), ndraws = 200, seed = 1,
              simulator = m$simulator)
  expect_equal(p[[2]], p[[1]])
})

test_that("with missing field data the extension agrees at an unmeasured library setting", {
  m <- machine()
  y <- m$field$y
  y[5, 1] <- NA
  field <- field_data(y, x = m$x)
  fit <- suppressWarnings(calibrate(m$library, field, n_iter = 800, burn_in = 100, seed = 1,
                                    discrepancy = knowledge()))
  x_new <- m$x[c(5, 6), , drop = FALSE]
  delta <- new_delta(fit, x_new, seq_len(nrow(fit$draws)), integer(0))
  expect_equal(delta$mean, discrepancy_moments(fit)$mean[c(5, 6)], tolerance = 1e-6)
})

test_that("a refined fit predicts at new settings from the runs refine() added too", {
  m <- machine(gap = FALSE)
  coarse <- sim_library(data.frame(theta = seq(0.3, 1, by = 0.05)),
                        outer(seq(0.3, 1, by = 0.05), m$x$x), x = m$x)
  fit <- suppressWarnings(calibrate(coarse, m$field, n_iter = 1000, burn_in = 200, seed = 1))
  refined <- suppressWarnings(refine(fit, function(theta) outer(theta$theta, m$x$x), seed = 1))
  seen <- new.env()
  recording <- function(theta, x) {
    seen$theta <- c(seen$theta, theta$theta)
    outer(theta$theta, x$x)
  }
  p <- extrapolate(refined, newdata = data.frame(x = 6), simulator = recording, seed = 1)
  expect_true(all(seen$theta %in% lib_theta(refined$library)$theta))
  expect_true(any(!seen$theta %in% lib_theta(coarse)$theta))
  expect_true(p$lower <= 6 * 0.65 && 6 * 0.65 <= p$upper)
})

test_that("noise groups by t and the field's sd carry to new settings", {
  sys <- bump_sys(n_t = 6)
  t <- lib_t(sys$library)
  simulator <- function(theta, x) {
    t(vapply(theta$k, function(k) unlist(lapply(x$amp, function(a) k * a * (1 + t))),
             numeric(nrow(x) * length(t))))
  }
  y <- matrix(sys$field$y, 3)
  grouped <- suppressWarnings(calibrate(sys$library, sys$field, n_iter = 400, burn_in = 100,
                                        seed = 1, noise_groups = rep(c("a", "b"), each = 3)))
  p <- extrapolate(grouped, newdata = data.frame(amp = 4), ndraws = 300, seed = 1,
               simulator = simulator)
  expect_true(all(is.finite(p$pred_lower) & p$pred_lower < p$lower))
  # an sd per t is the same at every setting: a new setting's noise has it
  per_t <- field_data(y, x = data.frame(amp = 1:3), t = t, sd = rep(c(1, 3), each = 3))
  fit <- suppressWarnings(calibrate(sys$library, per_t, n_iter = 400, burn_in = 100, seed = 1))
  p <- extrapolate(fit, newdata = data.frame(amp = 4), ndraws = 2000, seed = 1,
               simulator = simulator)
  noise <- (p$pred_upper - p$pred_lower) - (p$upper - p$lower)
  expect_gt(min(noise[4:6]), 2 * max(noise[1:3]))
  # an sd per setting is not known at a new one: no predictive bound there
  per_x <- field_data(y, x = data.frame(amp = 1:3), t = t, sd = c(1, 2, 3))
  fit <- suppressWarnings(calibrate(sys$library, per_x, n_iter = 400, burn_in = 100, seed = 1))
  p <- extrapolate(fit, newdata = data.frame(amp = 4), ndraws = 300, seed = 1,
               simulator = simulator)
  expect_true(all(is.na(p$pred_lower)) && all(is.finite(p$lower)))
})

# The emulated toy (helper-emulated.R) as a simulator: one row per theta,
# blocks of its 10 times by setting.
emulated_toy_simulator <- function(theta, x) {
  theta <- as.matrix(theta[c("k", "c")])
  do.call(cbind, lapply(x$x, function(v) emulated_sim(v, theta)))
}

test_that("an emulated library predicts inside its design's x range from its emulator", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library()
  fit <- suppressWarnings(calibrate(lib, emulated_toy_field(), n_iter = 2000, burn_in = 200,
                                    seed = 1))
  at <- data.frame(x = c(0.35, 0.95))
  p <- extrapolate(fit, newdata = at, ndraws = 2000, seed = 1)
  truth <- as.vector(emulated_toy_simulator(data.frame(k = 2.1, c = 0.3), at))
  expect_gte(mean(p$pred_lower <= truth & truth <= p$pred_upper), 0.95)
  # as the simulator's prediction, within the emulator's error
  ps <- extrapolate(fit, newdata = at, ndraws = 2000, seed = 1, simulator = emulated_toy_simulator)
  expect_lt(max(abs(p$mean - ps$mean)), 0.02)
  # at t = 0 the toy is sin(x) whatever theta: the simulator's band is a
  # point, the emulator's is its own error, +-1.96 sd of it
  t0 <- which(p$t == 0)
  expect_equal(ps$upper[t0] - ps$lower[t0], c(0, 0))
  run <- which.max(tabulate(fit$draws$run))
  sd <- attr(emulated_outputs(lib, lib_theta(lib)[run, , drop = FALSE], at), "sd")[1, t0]
  expect_equal((p$upper[t0] - p$lower[t0]) / (2 * 1.96 * sd), c(1, 1), tolerance = 0.15)
  # library settings keep today's answer
  expect_identical(predict(fit, newdata = data.frame(x = 0.5), ndraws = 300, seed = 1),
                   predict(fit, newdata = data.frame(x = 0.5), ndraws = 300, seed = 1,
                           simulator = emulated_toy_simulator))
})

test_that("beyond the design's x range, or without a design, new settings are classed errors", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 300)
  fit <- suppressWarnings(calibrate(lib, emulated_toy_field(), n_iter = 300, burn_in = 50,
                                    seed = 1))
  expect_error(predict(fit, newdata = data.frame(x = c(0.5, 0.6, 1.5))),
               "x = 1.5 outside the design's \\[0.003", class = "griddy_error_prediction")
  # 5% of the design's width beyond it is still reached (emulated_library()'s rule)
  expect_true(design_reach(lib, data.frame(x = 1.01))$ok)
  expect_false(design_reach(lib, data.frame(x = 1.04))$ok)
  m <- machine()
  expect_error(predict(machine_fit(m, n_iter = 300), newdata = data.frame(x = 3)),
               "not emulated from a design", class = "griddy_error_prediction")
})

test_that("a complete design's emulator (theta form) is refitted jointly for new settings", {
  skip_if_not_installed("RobustGaSP")
  theta <- expand.grid(k = seq(1, 3, length.out = 6), c = seq(0.1, 0.5, length.out = 5))
  grid <- merge(data.frame(x = c(0.2, 0.5, 0.8)), theta)
  y <- t(vapply(seq_len(nrow(grid)), function(i) {
    emulated_sim(grid$x[i], as.matrix(grid[i, c("k", "c")]))
  }, numeric(10)))
  lib <- emulated_library(grid[c("k", "c")], y, x = grid["x"], t = seq(0, 2, length.out = 10),
                          settings = data.frame(x = c(0.2, 0.5, 0.8)), n_runs = 1000, seed = 1)
  expect_identical(lib_design_emulator(lib)$mode, "theta")
  th <- data.frame(k = c(1.5, 2.5), c = c(0.2, 0.4))
  got <- emulated_outputs(lib, th, data.frame(x = 0.35))
  expect_lt(max(abs(got - emulated_toy_simulator(th, data.frame(x = 0.35)))), 0.02)
  expect_true(all(attr(got, "sd") > 0))
})

test_that("an .rds chunk library (disk_library) predicts at new settings as in memory", {
  m <- machine()
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(m$library, dir, chunk_size = 100)
  on_disk <- disk_library(dir, trust = TRUE)
  fits <- lapply(list(m$library, on_disk), function(lib) {
    suppressWarnings(calibrate(lib, m$field, n_iter = 600, burn_in = 100, seed = 1,
                               discrepancy = knowledge()))
  })
  p <- lapply(fits, predict, newdata = data.frame(x = c(3, 6)), ndraws = 200, seed = 1,
              simulator = m$simulator)
  expect_identical(p[[2]], p[[1]])
  expect_true(all(is.na(p[[1]]$observed[2]) & is.finite(p[[1]]$pred_upper)))
})

test_that("a refined fit of an emulated library predicts new settings from its base's emulator", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 400)
  fit <- suppressWarnings(calibrate(lib, emulated_toy_field(), n_iter = 600, burn_in = 100,
                                    seed = 1))
  refined <- suppressWarnings(refine(fit, seed = 1))
  expect_s3_class(refined$library, "refined_library")
  at <- data.frame(x = 0.65)
  p <- predict(refined, newdata = at, ndraws = 500, seed = 1)
  truth <- as.vector(emulated_toy_simulator(data.frame(k = 2.1, c = 0.3), at))
  expect_gte(mean(p$pred_lower <= truth & truth <= p$pred_upper), 0.9)
  # its runs are the refined library's, added ones included
  runs <- unique(refined$draws$run)
  expect_true(any(runs > lib_n_runs(lib)))
  expect_error(predict(refined, newdata = data.frame(x = 2)), "outside the design's",
               class = "griddy_error_prediction")
})

test_that("an emulated library's fit with a discrepancy extends it to new settings", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 1000)
  fit <- suppressWarnings(calibrate(lib, emulated_toy_field(), n_iter = 800, burn_in = 200,
                                    seed = 1, discrepancy = gp_discrepancy()))
  at <- data.frame(x = 0.65)
  p <- predict(fit, newdata = at, ndraws = 1000, seed = 1)
  truth <- as.vector(emulated_toy_simulator(data.frame(k = 2.1, c = 0.3), at))
  expect_gte(mean(p$pred_lower <= truth & truth <= p$pred_upper), 0.9)
  alone <- predict(fit, newdata = at, ndraws = 1000, seed = 1, discrepancy = FALSE)
  expect_gt(mean(p$upper - p$lower), mean(alone$upper - alone$lower))
})
