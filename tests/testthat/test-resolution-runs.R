test_that("11 effective runs in 11 parameters are not resolved", {
  p <- c(rep(1 / 11, 11), rep(0, 989))
  runs <- run_resolution(p, 11L)
  expect_equal(runs$effective_runs, 11)
  expect_identical(runs$needed, 220)
  expect_false(runs$resolved)
  expect_match(run_resolution_reason(runs), "11 effective runs \\(220 needed for 11 parameters\\)")
})

test_that("spread weights with a light tail are resolved; a heavy tail is not", {
  set.seed(1)
  light <- exp(-stats::rexp(4000))
  runs <- run_resolution(light / sum(light), 8L)
  expect_gt(runs$effective_runs, runs$needed)
  expect_lt(runs$pareto_k, runs$k_threshold)
  expect_true(runs$resolved)
  expect_null(run_resolution_reason(runs))
  # Pareto weights of tail index 1 / 0.9: k-hat near 0.9
  heavy <- stats::runif(4000)^(-0.9)
  runs <- run_resolution(heavy / sum(heavy), 8L)
  expect_gt(runs$pareto_k, runs$k_threshold)
  expect_false(runs$resolved)
  expect_match(run_resolution_reason(runs), "Pareto k-hat")
})

test_that("the run-level test applies from four parameters", {
  p <- c(0.5, 0.5, rep(0, 98))
  expect_true(run_resolution(p, 3L)$resolved)
  expect_false(run_resolution(p, 4L)$resolved)
  expect_true(is.na(run_resolution(p, 3L)$pareto_k))
})

test_that("a scattered library whose runs each have their own values is limited by its runs", {
  # 11 runs in 11 parameters: every marginal has 11 effective values,
  # yet the posterior rests on 11 runs
  set.seed(2)
  theta <- as.data.frame(matrix(stats::runif(1000 * 11), ncol = 11))
  p <- c(rep(1 / 11, 11), rep(0, 989))
  tab <- resolution_table(p, theta)
  expect_true(all(tab$effective_values > 10))
  expect_true(all(tab$limited))
  expect_equal(tab$effective_runs, rep(11, 11))
  expect_match(run_resolution_reason(attr(tab, "runs")), "^11 effective runs")
})

test_that("the reason names the parameters, also where the floor of effective runs applies", {
  runs <- run_resolution(c(0.5, 0.5, rep(0, 98)), 4L)
  expect_identical(runs$needed, 100)
  expect_match(run_resolution_reason(runs), "100 needed for 4 parameters", fixed = TRUE)
})

test_that("11 parameters on a few effective runs stay limited through calibrate() and refine() without a simulator", {
  # issue 24's Al-5083: 11 parameters, 12 outputs; refine() without a
  # simulator used to end with every parameter "resolved" on 11 effective
  # runs. Here the posterior rests on 10 to 220 effective runs: each
  # marginal has more than 10 effective values (the per-parameter test alone
  # passes), the run-level test fails
  skip_if_not_installed("RobustGaSP")
  set.seed(11)
  n <- 300
  theta <- as.data.frame(matrix(stats::runif(n * 11), ncol = 11,
                                dimnames = list(NULL, paste0("th", 1:11))))
  weights <- 0.04 * matrix(stats::rnorm(11 * 12), 11, 12)
  sim <- function(th) as.matrix(th) %*% weights
  lib <- sim_library(theta, sim(theta))
  field <- field_data(drop(sim(matrix(0.5, 1, 11))) + stats::rnorm(12, sd = 0.1))
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 600, burn_in = 100, seed = 1))
  s <- summary(fit)
  adequacy <- attr(s, "adequacy")$parameters
  runs <- attr(adequacy, "runs")
  expect_true(all(adequacy$effective_values > 10))
  expect_lt(runs$effective_runs, runs$needed)
  expect_identical(unique(s$resolution[s$parameter %in% names(theta)]), "limited")

  classes <- character()
  ref <- withCallingHandlers(refine(fit, max_runs = 400, seed = 1), warning = function(w) {
    # every class: a resolution warning may be a reach warning first
    # (griddy_warning_reach, refine-ridge.R)
    classes <<- c(classes, class(w))
    invokeRestart("muffleWarning")
  })
  expect_true("griddy_warning_resolution" %in% classes)
  expect_identical(ref$refinement$reason, "max_runs")
  s_ref <- summary(ref)
  adequacy_ref <- attr(s_ref, "adequacy")$parameters
  runs_ref <- attr(adequacy_ref, "runs")
  expect_true(all(adequacy_ref$effective_values > 10))
  expect_lt(runs_ref$effective_runs, runs_ref$needed)
  expect_false(runs_ref$resolved)
  expect_identical(unique(s_ref$resolution[s_ref$parameter %in% names(theta)]), "limited")
})
