test_that("griddy_threads() follows the option within the limits R's conventions set", {
  withr::local_envvar(`_R_CHECK_LIMIT_CORES_` = "", OMP_THREAD_LIMIT = "", OMP_NUM_THREADS = "")
  withr::local_options(griddy.threads = NULL)
  cores <- omp_limits_cpp()[1]
  # the default: the idle physical cores (which change from call to call),
  # within the limits
  expect_gte(griddy_threads(), 1L)
  expect_lte(griddy_threads(), min(omp_limits_cpp(), physical_cores()))
  withr::local_envvar(OMP_THREAD_LIMIT = "1")
  expect_identical(griddy_threads(), 1L)
  withr::local_envvar(OMP_THREAD_LIMIT = "")
  withr::local_options(griddy.threads = 1)
  expect_identical(griddy_threads(), 1L)
  # never more than the logical CPUs
  withr::local_options(griddy.threads = 1000)
  expect_identical(griddy_threads(), as.integer(min(omp_limits_cpp())))
  # R CMD check --as-cran: at most 2
  withr::local_envvar(`_R_CHECK_LIMIT_CORES_` = "TRUE")
  expect_lte(griddy_threads(), 2L)
  withr::local_envvar(`_R_CHECK_LIMIT_CORES_` = "false", OMP_THREAD_LIMIT = "1")
  expect_identical(griddy_threads(), 1L)
})

test_that("a bad griddy.threads option is a classed error", {
  for (bad in list(0, 1.5, "two", c(1, 2), NA)) {
    withr::local_options(griddy.threads = bad)
    expect_error(griddy_threads(), class = "griddy_error_input", regexp = "griddy.threads")
  }
})

test_that("parallel workers share the threads", {
  withr::local_envvar(`_R_CHECK_LIMIT_CORES_` = "", OMP_THREAD_LIMIT = "", OMP_NUM_THREADS = "")
  withr::local_options(griddy.threads = 1)
  expect_identical(threads_per_worker(4), 1L)
  skip_if(min(omp_limits_cpp()) < 2, "one thread only")
  withr::local_options(griddy.threads = 2)
  expect_identical(threads_per_worker(2), 1L)
  expect_identical(threads_per_worker(1), 2L)
})

test_that("the default leaves out the cores that other work keeps busy", {
  # /proc/loadavg: 1-, 5- and 15-minute averages, runnable/all tasks, last pid
  idle <- function(line, logical = 8, physical = 4) idle_cores(logical, physical, line)
  # only this process runs: every physical core
  expect_identical(idle("0.90 0.50 0.20 1/300 123"), 4)
  # hyperthreads do not count
  expect_identical(idle("0.00 0.00 0.00 1/300 123", physical = Inf), 8)
  # 6 other tasks runnable now, or on average over the last minute
  expect_identical(idle("0.50 0.50 0.50 7/300 123"), 2)
  expect_identical(idle("7.20 5.00 3.00 1/300 123"), 2)
  # a busy machine: one thread (griddy_threads() keeps at least one)
  expect_lte(idle("12.0 9.0 9.0 13/300 123"), 0)
  # no /proc/loadavg (not Linux): the physical cores
  expect_identical(idle(""), 4)
  expect_identical(idle(NA_character_), 4)
})

test_that("the load average is read at most once a second", {
  thread_cache$loadavg <- "0.00 0.00 0.00 1/100 1"
  thread_cache$loadavg_at <- proc.time()[["elapsed"]]
  expect_identical(read_loadavg(), "0.00 0.00 0.00 1/100 1")
  skip_if_not(file.exists("/proc/loadavg"))
  expect_false(identical(read_loadavg(max_age = -1), "0.00 0.00 0.00 1/100 1"))
})
