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

test_that("cheap maps stay in this process on a cluster scheduler's plan", {
  skip_if_not_installed("future.apply")
  skip_if_not_installed("future.batchtools")
  skip_on_cran()
  # a batchtools plan with 2 workers: simulations may go there, chains not
  # (a job's wait is longer than the chains take; found running refine() on
  # Slurm, where calibrate()'s chains became Slurm jobs)
  oplan <- future::plan(future.batchtools::batchtools_multicore, workers = 2)
  withr::defer(future::plan(oplan))
  expect_equal(griddy_workers(), 2L)
  expect_equal(griddy_workers(scheduled = FALSE), 1L)
  here <- griddy_map(1:2, function(i) Sys.getpid(), scheduled = FALSE)
  expect_equal(unlist(here), rep(Sys.getpid(), 2))
  future::plan(future::multisession, workers = 2)
  expect_equal(griddy_workers(scheduled = FALSE), 2L)
})

test_that("griddy_map() runs the map here when a worker is lost, with the same results", {
  skip_if_not_installed("future.apply")
  skip_on_cran()
  skip_if_not(installed_griddy_is_current("griddy_map"), "the installed griddy is not this version")
  marker <- withr::local_tempfile()
  # element 3 kills its worker (not this process) the first time: a lost
  # node, or a batch job the scheduler reports expired (a FutureError)
  f <- function(x, marker, main) {
    if (x == 3 && Sys.getpid() != main && !file.exists(marker)) {
      file.create(marker)
      tools::pskill(Sys.getpid(), tools::SIGKILL)
    }
    c(x, stats::runif(1))
  }
  environment(f) <- globalenv()
  lapplied <- griddy_map(1:4, f, marker = marker, main = Sys.getpid(), seeds = 1:4)
  oplan <- future::plan(future::multisession, workers = 2)
  withr::defer(future::plan(oplan))
  expect_equal(griddy_map(1:4, f, marker = marker, main = Sys.getpid(), seeds = 1:4), lapplied)
  expect_true(file.exists(marker))
})
