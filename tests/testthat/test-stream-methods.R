# What a stream answers: evidence, summaries, draws.

test_that("the log evidence is the sum of the one-step predictive densities", {
  ex <- griddy_example()
  s <- griddy_stream(ex$library, rho_t = c(0, 0.5))
  expect_equal(as.numeric(logLik(s)), 0)
  steps <- vapply(1:6, function(j) {
    before <- as.numeric(logLik(s))
    update(s, y = ex$field$y[2, j], x = ex$field$x[2, , drop = FALSE], t = ex$library$t[j])
    as.numeric(logLik(s)) - before
  }, numeric(1))
  both <- stream_vs_batch(s, ex$library, rho_t = c(0, 0.5))
  expect_equal(sum(steps), both$batch$log_evidence, tolerance = 1e-10)
})

test_that("summary, coef and confint are the exact posterior's, with the resolution warning", {
  ex <- griddy_example()
  s <- update(griddy_stream(ex$library, rho_t = c(0, 0.5)), y = ex$field)
  exact <- posterior_exact(ex$library, ex$field, rho_t = c(0, 0.5))
  theta <- ex$library$theta
  expect_warning(sm <- summary(s), class = "griddy_warning_resolution")
  expect_s3_class(sm, "griddy_stream_summary")
  expect_equal(sm$mean[sm$parameter == "k"], sum(exact$run * theta$k))
  expect_equal(sm$mean[sm$parameter == "rho_t"], sum(exact$grid$prob * exact$grid$rho_t))
  tab <- resolution_table(exact$run, theta)
  expect_equal(sm$lower[1:2], tab$lower)
  expect_equal(attr(sm, "effective_runs"), 1 / sum(exact$run^2))
  expect_equal(suppressWarnings(coef(s))[["c"]], sum(exact$run * theta$c))
  ci <- suppressWarnings(confint(s, "k", level = 0.9))
  expect_equal(dim(ci), c(1L, 2L))
  expect_equal(unname(ci[1, ]), resolution_table(exact$run, theta, 0.9)$lower[1] *
                 c(1, 0) + resolution_table(exact$run, theta, 0.9)$upper[1] * c(0, 1))
  expect_output(print(s), "griddy_stream")
  expect_output(print(suppressWarnings(summary(s))), "log evidence")
})

test_that("a few measurements leave the posterior resolved (no warning)", {
  ex <- griddy_example()
  s <- update(griddy_stream(ex$library), y = ex$field$y[1, 1:2],
              x = ex$field$x[1, , drop = FALSE], t = ex$library$t[1:2])
  expect_warning(summary(s), NA)
})

test_that("draws follow the exact joint posterior and reproduce with a seed", {
  ex <- griddy_example()
  s <- update(griddy_stream(ex$library, rho_t = c(0, 0.5)), y = ex$field)
  exact <- posterior_exact(s)
  d <- stream_draws(s, 4000, seed = 7)
  expect_identical(d, stream_draws(s, 4000, seed = 7))
  expect_equal(d$k, ex$library$theta$k[d$run])
  top <- which.max(exact$run)
  expect_equal(mean(d$run == top), exact$run[top], tolerance = 0.05)
  expect_equal(mean(d$rho_t == 0.5), exact$grid$prob[2], tolerance = 0.05)
  expect_true(all(d$tau > 0))
  # tau | run, grid point is Gamma(a + n/2, b + C/2): its mean near n / C
  expect_equal(mean(1 / d$tau), sum(exact$joint * s$state$C) / nobs(s), tolerance = 0.1)
  expect_error(stream_draws(griddy_stream(ex$library), 10), class = "griddy_error_input")
})

test_that("logLik needs a proper prior", {
  ex <- griddy_example()
  s <- update(griddy_stream(ex$library, prior = list(shape = 1, rate = 0)), y = ex$field)
  expect_true(is.na(logLik(s)))
  expect_equal(posterior_exact(s)$run,
               posterior_exact(ex$library, ex$field, prior = list(shape = 1, rate = 0))$run,
               tolerance = 1e-10)
})

test_that("the evidence of a larger library is the batch one", {
  set.seed(4)
  n <- 40000
  theta <- data.frame(a = runif(n), b = runif(n))
  tt <- seq(0, 1, length.out = 6)
  lib <- sim_library(theta, outer(theta$a, tt) + outer(theta$b, tt^2), t = tt)
  y <- 0.4 * tt + 0.7 * tt^2 + rnorm(6, sd = 0.05)
  s <- update(griddy_stream(lib, rho_t = c(0, 0.6)), y = y, t = tt)
  batch <- suppressWarnings(posterior_exact(lib, field_data(y, t = tt), rho_t = c(0, 0.6),
                                            joint = FALSE))
  expect_equal(as.numeric(logLik(s)), batch$log_evidence, tolerance = 1e-12)
  expect_equal(posterior_exact(s, joint = FALSE)$run, batch$run, tolerance = 1e-12)
})

test_that("the stream's evidence is the exact posterior's log mass, pruned path included (issue 32)", {
  # a concentrated posterior (small noise, many measurements): most
  # (run, grid point) entries lie beyond the cut and are never summed
  set.seed(6)
  n <- 5000
  theta <- data.frame(a = runif(n), b = runif(n))
  tt <- seq(0, 1, length.out = 40)
  lib <- sim_library(theta, outer(theta$a, tt) + outer(theta$b, tt^2), t = tt)
  y <- 0.4 * tt + 0.7 * tt^2 + rnorm(40, sd = 0.01)
  s <- update(griddy_stream(lib, rho_t = c(0, 0.3)), y = y, t = tt)
  batch <- suppressWarnings(posterior_exact(lib, field_data(y, t = tt), rho_t = c(0, 0.3),
                                            joint = FALSE))
  # the full sum in R, every entry included
  p <- stream_problem(s$state)
  lj <- collapsed_log_joint(p$C, s$state$n, s$state$logdet, s$state$prior,
                            s$state$log_prior_run, s$state$log_prior_grid)
  expect_gt(mean(lj < max(lj) - log(length(lj)) - 37), 0.5)
  expect_equal(as.numeric(logLik(s)), log_sum_exp(lj), tolerance = 1e-13)
  expect_equal(as.numeric(logLik(s)), batch$log_evidence, tolerance = 1e-12)
  # one routine: the stream's evidence is posterior_exact()'s of the stream, bit for bit
  expect_identical(as.numeric(logLik(s)), posterior_exact(s, joint = FALSE)$log_evidence)
  # and it does not depend on the number of threads
  evidence <- function(threads) {
    withr::local_options(griddy.threads = threads)
    s$state$cache <- NULL
    as.numeric(logLik(s))
  }
  expect_identical(evidence(2L), evidence(1L))
})
