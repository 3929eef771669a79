test_that("run weights are normalised and validated", {
  lib4 <- sim_library(data.frame(k = 1:4), matrix(1:8, 4))
  lib2 <- sim_library(data.frame(k = 1:2), matrix(1:4, 2))
  expect_equal(exp(log_run_weights(NULL, lib4)), rep(0.25, 4))
  expect_equal(exp(log_run_weights(c(1, 3), lib2)), c(0.25, 0.75))
  expect_error(log_run_weights(1:3, lib2), "one weight per library run \\(2\\); received 3")
  expect_error(log_run_weights(c(-1, 2), lib2), ">= 0 with a positive sum")
})

test_that("an exact reproduction with a zero prior rate is refused", {
  lib <- sim_library(data.frame(k = 1:3), matrix(c(1, 2, 3, 4, 5, 6), 3))
  f <- field_data(c(2, 5))
  expect_error(local_problem(lib, f, prior = list(shape = 1, rate = 0)),
               "reproduces the field data exactly")
  expect_silent(local_problem(lib, f, prior = list(shape = 1, rate = 1e-9)))
})

test_that("log_sum_exp is stable", {
  expect_equal(log_sum_exp(c(-1000, -1000)), -1000 + log(2))
  expect_equal(log_sum_exp(c(800, 0)), 800)
})

test_that("the default prior warns when the outputs' units make it matter", {
  toy <- toy_ar1(n_runs = 60, n_t = 30, sd = 0.3)
  small <- sim_library(toy$library$theta, toy$library$y * 1e-6, t = toy$library$t)
  small_field <- field_data(toy$field$y * 1e-6)
  # the finding: in units 1e-6 smaller the vague prior flattens the posterior
  expect_warning(p_small <- posterior_exact(small, small_field), class = "griddy_warning_prior")
  p <- expect_silent(posterior_exact(toy$library, toy$field))
  expect_gt(sum(abs(p$run - p_small$run)) / 2, 0.5)
  # a scale-free prior gives the same answer in any units, with no warning
  zero <- list(shape = 1e-9, rate = 0)
  expect_silent(p0_small <- posterior_exact(small, small_field, prior = zero))
  expect_equal(posterior_exact(toy$library, toy$field, prior = zero)$run, p0_small$run,
               tolerance = 1e-8)
  # a prior the user chose is not second-guessed
  expect_silent(posterior_exact(small, small_field, prior = list(shape = 1, rate = 1)))
})

test_that("a discrepancy's large ratios do not make the default prior warn (issue 33)", {
  # logistic growth without a gap, outputs near 1: the prior is negligible,
  # but the smallest quadratic form over all grid points (at the largest
  # discrepancy ratio, an improbable grid point) made it warn
  x <- data.frame(y0 = c(0.02, 0.05, 0.1))
  t <- 1:15
  sim <- function(r) 1 / (1 + outer(1 / x$y0 - 1, exp(-r * t)))
  r <- seq(0.5, 0.7, by = 1e-3)
  lib <- sim_library(data.frame(r = r), t(vapply(r, function(v) as.vector(t(sim(v))),
                                                 numeric(45))), x = x, t = t)
  set.seed(4018)
  f <- field_data(sim(stats::runif(1, 0.55, 0.65)) + stats::rnorm(45, sd = 0.02), x = x, t = t)
  expect_no_warning(posterior_exact(lib, f, discrepancy = gp_discrepancy(), joint = FALSE),
                    class = "griddy_warning_prior")
})

test_that("the grid prior is uniform over distinct correlation structures, not grid points", {
  # two x columns in which every setting differs: rho_j = 0 in either makes
  # R_x the identity, so 11 of the 36 grid points are independence
  x <- data.frame(a = c(1, 2, 3), b = c(5, 7, 6))
  lib <- sim_library(data.frame(k = 1:2), matrix(rnorm(6), 2), x = x)
  rho <- c(0, 0.2, 0.4, 0.6, 0.8, 0.9)
  pr <- local_problem(lib, field_data(rnorm(3), x = x), rho_x = rho)
  indep <- pr$grid$rho_x_a == 0 | pr$grid$rho_x_b == 0
  expect_identical(sum(indep), 11L)
  # a uniform prior over grid points gave independence 11/36; now 1 of the
  # 26 distinct structures
  expect_equal(sum(exp(pr$log_prior_grid)), 1)
  expect_equal(sum(exp(pr$log_prior_grid[indep])), 1 / 26)
  expect_equal(exp(pr$log_prior_grid[!indep]), rep(1 / 26, 25))
  # one x column: every grid point its own structure, as before
  lib1 <- sim_library(data.frame(k = 1:2), matrix(rnorm(6), 2), x = x["a"])
  pr1 <- local_problem(lib1, field_data(rnorm(3), x = x["a"]), rho_x = rho)
  expect_equal(pr1$log_prior_grid, rep(-log(6), 6))
})

test_that("run_weights whose sum overflows are normalised, not an internal inverse-CDF error (issue 22)", {
  ex <- griddy_example()
  n <- lib_n_runs(ex$library)
  big <- suppressWarnings(calibrate(ex$library, ex$field, run_weights = rep(1e308, n),
                                    n_iter = 200, burn_in = 50, seed = 1))
  ref <- suppressWarnings(calibrate(ex$library, ex$field, run_weights = rep(1, n),
                                    n_iter = 200, burn_in = 50, seed = 1))
  expect_identical(big$draws$k, ref$draws$k)
  expect_error(calibrate(ex$library, ex$field, run_weights = rep(0, n)),
               "`run_weights` must be >= 0 with a positive sum")
  expect_error(calibrate(ex$library, ex$field, run_weights = c(Inf, rep(1, n - 1))),
               class = "griddy_error_input")
})
