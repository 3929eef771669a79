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
