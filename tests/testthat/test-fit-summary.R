test_that("summary has one row per sampled parameter with rank-normalised diagnostics", {
  toy <- toy_ar1(n_runs = 100, n_t = 30)
  fit <- calibrate(toy$library, toy$field, rho_t = c(0, 1e-3, 0.1), n_iter = 3000, burn_in = 500,
                   chains = 2, seed = 1)
  s <- summary(fit)
  expect_s3_class(s, "griddy_summary")
  expect_s3_class(s, "data.frame")
  expect_identical(s$parameter, c("theta", "tau", "rho_t"))
  expect_identical(names(s), c("parameter", "estimate", "estimate_type", "mean", "median",
                               "lower", "upper", "ess_bulk", "ess_tail", "rhat", "mcse",
                               "resolution"))
  d <- as.data.frame(fit)
  expect_equal(s$mean[1], mean(d$theta))
  expect_true(all(s$lower <= s$estimate & s$estimate <= s$upper))
  expect_true(all(s$lower <= s$median & s$median <= s$upper))
  expect_true(all(s$lower[1:2] %in% c(unique(d$theta), d$tau)))
  expect_true(all(s$ess_bulk > 100))
  expect_true(all(s$ess_tail[1:2] > 100))
  expect_true(all(abs(s$rhat - 1) < 0.1))
  m <- matrix(d$theta, ncol = 2)
  expect_equal(s$ess_bulk[1], posterior::ess_bulk(m))
  expect_equal(s$ess_tail[1], posterior::ess_tail(m))
  expect_equal(s$rhat[1], posterior::rhat(m))
  expect_equal(s$mcse[1], posterior::mcse_mean(m))
  narrow <- summary(fit, level = 0.5)
  expect_gte(narrow$lower[1], s$lower[1])
  # a subset keeps its level (it printed the 95% bounds' names)
  expect_identical(attr(narrow[1:2, ], "level"), 0.5)
  expect_match(paste(utils::capture.output(print(narrow[1, ])), collapse = "\n"), "25 %")
  expect_error(summary(fit, level = 1), "`level` must be a single number in \\(0, 1\\)")
  a <- attr(s, "adequacy")
  exact <- posterior_exact(toy$library, toy$field, rho_t = c(0, 1e-3, 0.1))$run
  expect_equal(a$effective_runs, 1 / sum(exact^2))
  expect_equal(a$parameters, resolution_table(exact, toy$library$theta))
  expect_equal(attr(narrow, "adequacy")$parameters,
               resolution_table(exact, toy$library$theta, level = 0.5))
  expect_lt(a$tv_distance, 0.2)
  expect_gt(a$tv_reference, 0)
  expect_lte(a$effective_draws, nrow(d))
})

test_that("one chain gives a split-chain rhat; print shows the table and the adequacy lines", {
  toy <- toy_ar1(n_runs = 40, n_t = 20)
  fit <- suppressWarnings(
    calibrate(toy$library, toy$field, n_iter = 1000, burn_in = 100, seed = 1),
    classes = "griddy_warning_resolution")
  s <- summary(fit)
  expect_true(all(is.finite(s$rhat)))
  expect_output(print(s), "ess_bulk ess_tail")
  expect_output(print(s, width = 200),
                "Monte Carlo error alone: [0-9.]+ at [0-9]+ effective draws")
  expect_output(print(s), "\nestimate: posterior mean\\.\n")
  expect_output(print(s), "collapsed update\\) over 40 runs x 1 correlation grid point")
  expect_output(print(s), "2.5 % 97.5 %")
  expect_output(print(s), "effective number of runs")
  expect_output(out <- print(fit), "theta")
  expect_identical(out, fit)
})

test_that("summary marks limited parameters and print explains them and edge mass", {
  toy <- toy_ar1(n_runs = 20, n_t = 60, sd = 0.01, lag_cor = 0, theta_true = 1)
  fit <- suppressWarnings(calibrate(toy$library, toy$field, n_iter = 300, burn_in = 100, seed = 1),
                          classes = "griddy_warning_resolution")
  s <- summary(fit)
  expect_identical(s$resolution, c("limited", NA))
  expect_output(print(fit, width = 200),
                paste0("theta: interval limited by the library's resolution ",
                       "\\(1.0 effective values; 10 needed\\); see \\?refine"))
  expect_output(print(fit, width = 200),
                paste0("theta: 100% of the posterior at the library's maximum; ",
                       "the truth may lie outside the library's range of theta"))
})

test_that("a fine library resolves its parameters and prints no resolution line", {
  toy <- toy_ar1(n_runs = 500, n_t = 10, sd = 0.3, lag_cor = 0)
  fit <- calibrate(toy$library, toy$field, n_iter = 1000, burn_in = 200, seed = 1)
  s <- summary(fit)
  expect_identical(s$resolution, c("resolved", NA))
  out <- utils::capture.output(print(s))
  expect_false(any(grepl("limited|outside the library's range", out)))
})

test_that("two parameters: each gets its own resolution", {
  # a 12 x 40 grid; data pin `a` between its 12 values, `b` spreads over its 40
  grid <- expand.grid(a = seq(0, 1, length.out = 12), b = seq(0, 1, length.out = 40))
  t <- seq(0, 1, length.out = 50)
  sim <- function(a, b) 5 * a * t + 0.05 * b * cos(3 * t)
  y <- t(mapply(sim, grid$a, grid$b))
  set.seed(2)
  f <- field_data(sim(0.52, 0.5) + stats::rnorm(50, sd = 0.1))
  fit <- suppressWarnings(calibrate(sim_library(grid, y, t = t), f, n_iter = 1000, burn_in = 200,
                                    seed = 1), classes = "griddy_warning_resolution")
  expect_identical(summary(fit)$resolution, c("limited", "resolved", NA))
})

# A fit whose tau is in the thousands (noise sd 0.025) beside a theta below 1.
precise_fit <- function() {
  toy <- toy_ar1(n_runs = 200, n_t = 60, sd = 0.025, lag_cor = 0)
  suppressWarnings(calibrate(toy$library, toy$field, n_iter = 1000, burn_in = 200, chains = 2,
                             seed = 1),
                   classes = "griddy_warning_resolution")
}

test_that("print formats each parameter on its own scale (tau ~2000 beside theta ~0.4)", {
  fit <- precise_fit()
  s <- summary(fit)
  expect_gt(s$median[2], 1000)
  expect_lt(s$median[1], 1)
  out <- utils::capture.output(print(s, width = 200))
  expect_false(any(grepl("e\\+", out)))
  # tau's estimate and bounds as whole numbers, theta's to 4 significant digits
  expect_match(out, "^ +tau +[0-9]{4} +[0-9]{4} +[0-9]{4} ", all = FALSE)
  expect_match(out, "^ +theta +0\\.[0-9]{4}\\*? +0\\.[0-9]{4} +0\\.[0-9]{4} ", all = FALSE)
  # the data.frame stays numeric
  expect_type(s$estimate, "double")
  expect_type(s$lower, "double")
})

test_that("a mean outside its own interval is reported as the median, and print says so", {
  # 98% of the draws on one value, 2% far off: the 95% interval is that value,
  # the mean beside it
  expect_equal(draws_estimates(c(rep(0.5, 98), rep(1, 2)), 0.95, type = 1),
               data.frame(estimate = 0.5, estimate_type = "median", mean = 0.51, median = 0.5,
                          lower = 0.5, upper = 0.5))
  expect_identical(draws_estimates(c(0.2, 0.5, 0.5, 0.6), 0.95, type = 1)$estimate_type, "mean")
  # the same in a fit: its theta draws set to run 101 (theta 0.5025), every
  # 50th to run 200 (theta 1)
  fit <- precise_fit()
  fit$draws$run <- ifelse(seq_len(nrow(fit$draws)) %% 50 == 0, 200L, 101L)
  s <- summary(fit)
  expect_identical(s$estimate_type, c("median", "mean"))
  expect_identical(s$estimate[1], fit$library$theta$theta[101])
  expect_gt(s$mean[1], s$upper[1])
  expect_identical(s$estimate[2], s$mean[2])
  out <- utils::capture.output(print(s, width = 200))
  expect_match(out, "^ +theta +0\\.5025\\* ", all = FALSE)
  expect_match(out, paste0("^estimate: posterior mean; \\* posterior median, where the mean ",
                           "lies outside the 95% interval\\.$"), all = FALSE)
})

test_that("print keeps every line within width, from the argument or the option", {
  fit <- precise_fit()
  s <- summary(fit)
  for (width in c(40, 60, 100)) {
    out <- utils::capture.output(print(s, width = width))
    expect_lte(max(nchar(out)), width)
    expect_match(out, "^Griddy Gibbs", all = FALSE)
  }
  narrow <- withr::with_options(list(width = 50), utils::capture.output(print(fit)))
  expect_lte(max(nchar(narrow)), 50)
  expect_match(narrow, "ess_bulk", all = FALSE)
  # a subset of columns prints what it holds
  expect_output(print(s[c("parameter", "mean", "rhat")]), "parameter +mean +rhat")
})

test_that("print() explains an NA ess_tail: a tail quantile on the last value drawn", {
  toy <- toy_ar1(n_runs = 40, n_t = 20)
  fit <- suppressWarnings(
    calibrate(toy$library, toy$field, n_iter = 1000, burn_in = 100, chains = 2, seed = 1),
    classes = "griddy_warning_resolution")
  # 90% of the draws on one run and 10% on a run of larger theta: the 95%
  # quantile of theta is its largest value drawn
  low_high <- order(toy$library$theta$theta)[c(1, 40)]
  fit$draws$run <- ifelse(seq_len(nrow(fit$draws)) %% 10 == 0, low_high[2], low_high[1])
  s <- summary(fit)
  expect_true(is.na(s$ess_tail[1]) && !is.na(s$ess_bulk[1]))
  out <- paste(utils::capture.output(print(s, width = 300)), collapse = "\n")
  expect_match(out, "ess_tail NA: the 95% quantile of theta is its largest value drawn",
               fixed = TRUE)
  # no note where every tail ESS is there
  expect_identical(ess_tail_note(s[2, ]), character())
})

test_that("print.griddy_fit() and print.griddy_summary() are stable (times scrubbed)", {
  ex <- griddy_example()
  fit <- suppressWarnings(calibrate(ex$library, ex$field, n_iter = 2000, burn_in = 500,
                                    seed = 1, progress = FALSE))
  # wide: how the times wrap would depend on their digits
  expect_snapshot(print(fit, width = 250), transform = scrub_print)
  expect_snapshot(print(summary(fit), width = 250), transform = scrub_print)
})

test_that("theta_estimand() says what theta is under each discrepancy", {
  # issue 33: the orthogonal default estimates another theta than SEPIA,
  # SAVE and RobustCalibration, and nothing in the output said so
  orthogonal <- theta_estimand(gp_discrepancy())
  expect_match(orthogonal, "theta is the best-fitting value, not the physical one: the L2 projection",
               fixed = TRUE)
  expect_match(orthogonal, "not the Kennedy-O'Hagan theta that SEPIA, SAVE and RobustCalibration",
               fixed = TRUE)
  koh <- theta_estimand(gp_discrepancy(orthogonal = FALSE))
  expect_match(koh, "theta is Kennedy and O'Hagan's, as SEPIA, SAVE and RobustCalibration report",
               fixed = TRUE)
  expect_match(koh, "not necessarily the physical one", fixed = TRUE)
  known <- theta_estimand(gp_discrepancy(zero_at = data.frame(x = 0)))
  expect_match(known, "the physical value to the extent that the knowledge holds", fixed = TRUE)
  expect_no_match(known, "not the physical one", fixed = TRUE)
  expect_identical(theta_estimand(gp_discrepancy(flat_at = data.frame(x = 0))), known)
  # asked for, the projection hands theta the gap's share whatever the knowledge
  expect_identical(theta_estimand(gp_discrepancy(zero_at = data.frame(x = 0), orthogonal = TRUE)),
                   orthogonal)
  expect_null(theta_estimand(NULL))
})

test_that("print() and summary() of a fit state its discrepancy's estimand, and only then", {
  sys <- bump_sys(n_t = 5)
  printed <- function(discrepancy) {
    fit <- suppressWarnings(calibrate(sys$library, sys$field, n_iter = 300, burn_in = 100,
                                      seed = 1, discrepancy = discrepancy))
    list(fit = paste(capture.output(print(fit, width = 1000)), collapse = " "),
         summary = paste(capture.output(print(summary(fit), width = 1000)), collapse = " "))
  }
  cases <- list(gp_discrepancy(), gp_discrepancy(orthogonal = FALSE),
                gp_discrepancy(zero_at = data.frame(amp = 1, t = sys$library$t)))
  sentences <- lapply(cases, theta_estimand)
  expect_length(unique(sentences), 3L)
  for (i in seq_along(cases)) {
    out <- printed(cases[[i]])
    expect_match(out$fit, sentences[[i]], fixed = TRUE)
    expect_match(out$summary, sentences[[i]], fixed = TRUE)
    for (other in sentences[-i]) expect_no_match(out$fit, other, fixed = TRUE)
  }
  # a fit without a discrepancy claims none of them
  plain <- printed(NULL)
  for (sentence in sentences) expect_no_match(plain$fit, sentence, fixed = TRUE)
  for (words in c("L2 projection", "Kennedy", "physical value to the extent")) {
    expect_no_match(plain$fit, words, fixed = TRUE)
  }
})
