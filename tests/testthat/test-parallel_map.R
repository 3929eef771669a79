test_that("griddy_map() maps in this process without a plan, with each element's own seed", {
  out <- griddy_map(1:3, function(i, add) i + add, add = 10)
  expect_equal(out, list(11, 12, 13))
  set.seed(5)
  before <- stats::runif(1)
  set.seed(5)
  seeded <- griddy_map(list("a", "b"), function(x) stats::runif(1), seeds = c(1L, 2L))
  # R's stream is restored after the seeded map
  expect_equal(stats::runif(1), before)
  expect_equal(seeded[[1]], with_seed(1L, stats::runif(1)))
  expect_equal(seeded[[2]], with_seed(2L, stats::runif(1)))
})

test_that("griddy_map() uses the plan's workers and gives the same results", {
  skip_if_not_installed("future.apply")
  skip_on_cran()
  f <- function(x) c(x, stats::runif(1))
  lapplied <- griddy_map(1:4, f, seeds = 1:4)
  oplan <- future::plan(future::multisession, workers = 2)
  withr::defer(future::plan(oplan))
  expect_equal(griddy_workers(), 2L)
  expect_equal(griddy_map(1:4, f, seeds = 1:4), lapplied)
})
