test_that("predict gives the outputs at the drawn runs and wider noisy bounds", {
  toy <- toy_xt(n_per_dim = 5, n_t = 6)
  fit <- suppressWarnings(
    calibrate(toy$library, toy$field, rho_t = c(0, 0.3), n_iter = 1500, burn_in = 500,
              chains = 2, seed = 1),
    classes = "griddy_warning_resolution")
  p <- predict(fit, ndraws = 300, seed = 3)
  expect_identical(names(p), c("x", "load", "speed", "t", "observed", "mean", "lower", "upper",
                               "pred_lower", "pred_upper"))
  expect_identical(nrow(p), 18L)
  expect_identical(p$observed, field_vector(toy$library, toy$field))
  expect_equal(p$mean, colMeans(toy$library$y[fit$draws$run, ]))
  expect_true(all(p$lower <= p$upper))
  expect_true(all(p$pred_lower < p$lower & p$pred_upper > p$upper))
  # noise of sd 1 in the data: the predictive band should cover most points
  expect_gt(mean(p$observed >= p$pred_lower & p$observed <= p$pred_upper), 0.75)
  expect_identical(predict(fit, ndraws = 300, seed = 3), p)
  expect_error(predict(fit, level = 2), "`level`")
  expect_error(predict(fit, ndraws = 0), "`ndraws`")
})

test_that("noisy outputs have the covariance R_x (x) R_t / tau", {
  toy <- toy_xt(n_per_dim = 2, n_t = 4)
  fit <- suppressWarnings(
    calibrate(toy$library, toy$field, rho_x = list(load = 0.7, speed = 0.4), rho_t = 0.3,
              n_iter = 20, burn_in = 0, seed = 1),
    classes = "griddy_warning_resolution")
  fit$draws <- fit$draws[rep(1, 20000), ]
  fit$draws$tau <- 4
  set.seed(1)
  noise <- sweep(noisy_outputs(fit, seq_len(20000)), 2, toy$library$y[fit$draws$run[1], ])
  R <- kronecker(corr_x(toy$library$x, c(0.7, 0.4)), corr_t(toy$library$t, 0.3))
  expect_lt(max(abs(stats::cov(noise) - R / 4)), 0.02)
})

test_that("weighted_quantile inverts the weighted CDF", {
  expect_identical(weighted_quantile(c(3, 1, 2), c(0.2, 0.5, 0.3), c(0.4, 0.5, 0.81)), c(1, 1, 3))
})

test_that("predict(newdata =) predicts at the given library settings or stops", {
  toy <- toy_xt(n_per_dim = 4, n_t = 5)
  fit <- suppressWarnings(
    calibrate(toy$library, toy$field, n_iter = 600, burn_in = 100, seed = 1),
    classes = "griddy_warning_resolution")
  all <- predict(fit, ndraws = 100, seed = 2)
  two <- predict(fit, newdata = data.frame(speed = c(20, 10), load = c(3, 1)), ndraws = 100,
                 seed = 2)
  expect_identical(two$x, rep(c(3L, 1L), each = 5))
  expect_identical(two$observed, all$observed[c(11:15, 1:5)])
  expect_equal(two$mean, all$mean[c(11:15, 1:5)])
  expect_error(predict(fit, newdata = data.frame(load = 2.5, speed = 10)),
               class = "griddy_error_input", regexp = "row\\(s\\) 1 \\(load = 2.5")
  expect_error(predict(fit, newdata = data.frame(load = 1)), "lacks the library's x column")
  expect_error(predict(fit, newdata = list(load = 1, speed = 10)), "data.frame")
  one <- toy_ar1(n_runs = 20, n_t = 8)
  fit1 <- suppressWarnings(
    calibrate(one$library, one$field, n_iter = 200, burn_in = 50, seed = 1),
    classes = "griddy_warning_resolution")
  expect_error(predict(fit1, newdata = data.frame(x = 1)), "single x setting")
})

test_that("an x column named `x` keeps its name; the setting's row is then `setting`", {
  # the row column `x` and the x column `x` made two columns of one name
  lib <- x_named_x_library()
  fit <- suppressWarnings(calibrate(lib$library, lib$field, n_iter = 200, burn_in = 50, seed = 1),
                          classes = "griddy_warning_resolution")
  pred <- predict(fit, ndraws = 50, seed = 1)
  expect_identical(names(pred)[1:3], c("setting", "x", "t"))
  expect_false(anyDuplicated(names(pred)) > 0L)
  expect_identical(pred$setting, rep(1:3, each = 5))
  expect_identical(pred$x, rep(c(2, 4, 6), each = 5))
  at <- predict(fit, newdata = data.frame(x = 6), ndraws = 50, seed = 1)
  expect_identical(at$setting, rep(3L, 5))
  expect_identical(setting_column(toy_xt(n_per_dim = 3, n_t = 2)$library), "x")
})

test_that("predict() with missing data predicts every cell, and each noise group at its tau", {
  toy <- toy_missing()
  prior <- list(shape = 2, rate = 0.5)
  fit <- suppressWarnings(calibrate(toy$library, toy$field, noise_groups = "x", prior = prior,
                                    n_iter = 1500, burn_in = 500, seed = 1))
  p <- predict(fit, ndraws = 500, seed = 2)
  expect_identical(nrow(p), 15L)
  expect_identical(is.na(p$observed), is.na(toy$y))
  expect_true(all(is.finite(p$pred_lower) & p$pred_lower < p$lower))
  # a group's noise is that of its own tau: set them apart and look
  fit$draws$tau_x1 <- 1e4
  fit$draws$tau_x3 <- 1e-2
  set.seed(1)
  noisy <- noisy_outputs(fit, rep(1, 4000))
  base <- lib_outputs(fit$library, fit$draws$run[1])[1, ]
  sds <- apply(noisy, 2, stats::sd)
  expect_equal(sds[1:5], rep(0.01, 5), tolerance = 0.05)
  expect_equal(sds[11:15], rep(10, 5), tolerance = 0.05)
  # relative sd scales the noise
  f_sd <- field_data(toy$y, x = toy$x, t = toy$t, sd = c(1, 2, 3))
  fit2 <- suppressWarnings(calibrate(toy$library, f_sd, prior = prior, n_iter = 300,
                                     burn_in = 100, seed = 1))
  fit2$draws$tau <- 1
  set.seed(2)
  sds2 <- apply(noisy_outputs(fit2, rep(1, 4000)), 2, stats::sd)
  expect_equal(sds2, rep(1:3, each = 5), tolerance = 0.05)
})

test_that("predict(discrepancy = TRUE) adds delta's posterior: the bias-corrected prediction", {
  sys <- bump_sys()
  fit <- bump_fit(sys)
  with_delta <- predict(fit, ndraws = 300, seed = 1)
  expect_identical(predict(fit, ndraws = 300, seed = 1, discrepancy = TRUE), with_delta)
  alone <- predict(fit, ndraws = 300, seed = 1, discrepancy = FALSE)
  expect_identical(names(with_delta), names(alone))
  expect_equal(alone$mean, posterior_mean_outputs(fit))
  expect_equal(with_delta$mean - alone$mean, discrepancy_moments(fit)$mean)
  # the simulator alone misses the bump; with delta the mean follows the
  # field's mean and the intervals hold it
  bump <- sys$gap > 0.2
  expect_true(all(alone$upper[bump] < sys$truth[bump]))
  expect_lt(sqrt(mean((with_delta$mean - sys$truth)^2)),
            sqrt(mean((alone$mean - sys$truth)^2)) / 2)
  expect_gt(mean(with_delta$lower <= sys$truth & sys$truth <= with_delta$upper), 0.9)
  expect_true(all(with_delta$pred_lower <= with_delta$lower &
                    with_delta$pred_upper >= with_delta$upper))
  # one setting: the same draws, so the same rows
  amp3 <- predict(fit, newdata = data.frame(amp = 3), ndraws = 300, seed = 1)
  expect_equal(amp3, with_delta[with_delta$amp == 3, ], ignore_attr = TRUE)
  expect_error(predict(fit, discrepancy = NA), "`discrepancy`")
  plain <- suppressWarnings(calibrate(sys$library, sys$field, n_iter = 100, burn_in = 10,
                                      seed = 1))
  expect_identical(names(predict(plain, ndraws = 10, seed = 1)), names(alone))
  expect_error(predict(plain, discrepancy = TRUE), class = "griddy_error_input",
               regexp = "has no discrepancy")
})

test_that("predict(discrepancy = TRUE) reaches a setting the field does not measure", {
  sys <- bump_sys()
  y <- matrix(sys$field$y, 3)
  y[2, ] <- NA  # amp = 2 unmeasured
  fit <- suppressWarnings(calibrate(sys$library, field_data(y, x = data.frame(amp = 1:3),
                                                            t = lib_t(sys$library)),
                                    n_iter = 600, burn_in = 100, seed = 1,
                                    discrepancy = gp_discrepancy(orthogonal = FALSE)),
                          classes = c("griddy_warning_resolution", "griddy_warning_gap"))
  p <- predict(fit, ndraws = 300, seed = 1)
  expect_false(anyNA(p[c("mean", "lower", "upper", "pred_lower", "pred_upper")]))
  width <- tapply(p$upper - p$lower, p$amp, mean)
  expect_gt(width[["2"]], width[["1"]])
  expect_true(all(is.na(p$observed[p$amp == 2])))
})
