test_that("griddy_threads() follows the option within the limits R's conventions set", {
  withr::local_envvar(`_R_CHECK_LIMIT_CORES_` = "", OMP_THREAD_LIMIT = "", OMP_NUM_THREADS = "")
  withr::local_options(griddy.threads = NULL)
  cores <- omp_limits_cpp()[1]
  expect_identical(griddy_threads(), as.integer(min(omp_limits_cpp())))
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
