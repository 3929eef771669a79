test_that("the exact posterior matches numerical integration over tau", {
  lib <- sim_library(data.frame(k = c(0.8, 1, 1.3)), rbind(c(0.8, 1.6, 2.4), c(1, 2, 3), c(1.3, 2.6, 3.9)),
                     t = c(0, 0.5, 1))
  y <- c(1.1, 1.9, 3.2)
  prior <- list(shape = 2, rate = 0.5)
  rho <- 0.4
  R <- corr_t(lib$t, rho)
  Rinv <- solve(R)
  # p(y | run) = integral of N(y | g, R / tau) Gamma(tau | a, b) over tau
  marginal <- vapply(1:3, function(i) {
    r <- y - lib$y[i, ]
    q <- drop(crossprod(r, Rinv %*% r))
    f <- function(tau) {
      exp(3 / 2 * log(tau / (2 * pi)) - 0.5 * determinant(R)$modulus - tau / 2 * q +
            stats::dgamma(tau, prior$shape, prior$rate, log = TRUE))
    }
    stats::integrate(f, 0, Inf, rel.tol = 1e-10)$value
  }, numeric(1))
  ex <- posterior_exact(lib, field_data(y), rho_t = rho, prior = prior)
  expect_s3_class(ex, "griddy_exact")
  expect_equal(ex$run, marginal / sum(marginal), tolerance = 1e-7)
  expect_equal(ex$log_evidence, log(mean(marginal)), tolerance = 1e-7)
  expect_equal(ex$grid$prob, 1)
})

test_that("run and rho marginals sum to one and weights enter the prior", {
  toy <- toy_ar1(n_runs = 50, n_t = 20)
  ex <- posterior_exact(toy$library, toy$field, rho_t = c(0, 0.01, 0.2))
  expect_equal(sum(ex$run), 1)
  expect_equal(sum(ex$grid$prob), 1)
  expect_equal(rowSums(ex$joint), ex$run)
  expect_identical(names(ex$grid), c("rho_t", "prob"))
  w <- rep(1, 50)
  w[which.max(ex$run)] <- 0
  exw <- posterior_exact(toy$library, toy$field, rho_t = c(0, 0.01, 0.2), run_weights = w)
  expect_identical(exw$run[which.max(ex$run)], 0)
  expect_output(print(ex), "exact posterior over 50 runs x 3 correlation grid point")
})

test_that("joint = FALSE leaves out the joint table and keeps the same margins", {
  toy <- toy_ar1(n_runs = 50, n_t = 20)
  full <- posterior_exact(toy$library, toy$field, rho_t = c(0, 0.01, 0.2))
  margins <- posterior_exact(toy$library, toy$field, rho_t = c(0, 0.01, 0.2), joint = FALSE)
  expect_null(margins$joint)
  # without the joint, entries below exp(-37) / (N G) of the largest are left
  # out (src/exact_posterior.cpp): together under the rounding of the total
  expect_equal(margins$run, full$run, tolerance = 1e-15)
  expect_equal(margins$grid, full$grid, tolerance = 1e-15)
  expect_equal(margins$log_evidence, full$log_evidence, tolerance = 1e-15)
  expect_error(posterior_exact(toy$library, toy$field, joint = NA), class = "griddy_error",
               regexp = "`joint` must be TRUE or FALSE")
})

test_that("an improper prior gives no evidence", {
  toy <- toy_ar1(n_runs = 10, n_t = 8)
  expect_identical(posterior_exact(toy$library, toy$field, prior = list(shape = 1, rate = 0))$log_evidence,
                   NA_real_)
})

test_that("print.griddy_exact() shows the runs, the grid, the most probable runs and the evidence", {
  toy <- toy_ar1(n_runs = 60, n_t = 10)
  expect_snapshot(print(posterior_exact(toy$library, toy$field, rho_t = c(0, 0.5))))
})

test_that("posterior_exact() is a generic: a library and data, a fit, a stream (issue 32)", {
  toy <- toy_ar1(n_runs = 60, n_t = 20)
  batch <- posterior_exact(toy$library, toy$field, rho_t = c(0, 0.5))
  expect_true(is.function(getS3method("posterior_exact", "griddy_stream")))
  # a fit: the exact posterior of its own problem
  fit <- calibrate(toy$library, toy$field, rho_t = c(0, 0.5), n_iter = 200, burn_in = 50,
                   chains = 1, seed = 1)
  expect_equal(posterior_exact(fit), batch, tolerance = 1e-12)
  expect_null(posterior_exact(fit, joint = FALSE)$joint)
  # a stream: the exact posterior of the data so far
  s <- update(griddy_stream(toy$library, rho_t = c(0, 0.5)), y = toy$field)
  expect_equal(posterior_exact(s), batch, tolerance = 1e-10)
  expect_equal(posterior_exact(s, FALSE)$run, batch$run, tolerance = 1e-10)
  # the library form keeps its positional arguments
  expect_equal(posterior_exact(toy$library, toy$field, 0, c(0, 0.5)), batch)
  # arguments no method takes are errors, not silently dropped
  expect_error(posterior_exact(s, toy$field), "received griddy_field \\(a stream holds",
               class = "griddy_error_input")
  expect_error(posterior_exact(s, TRUE, toy$field), "of a stream takes no further argument",
               class = "griddy_error_input")
  expect_error(posterior_exact(fit, rho_t = 0.3), "`rho_t`", class = "griddy_error_input")
  expect_error(posterior_exact(toy$library, toy$field, rho_z = 0.5), "`rho_z`",
               class = "griddy_error_input")
})
