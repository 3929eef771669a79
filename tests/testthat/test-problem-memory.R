test_that("the memory statement gives C's size, the run order's and the library's", {
  lib <- sim_library(data.frame(k = seq_len(59319)), matrix(0, 59319, 2))
  expect_identical(memory_statement(lib, 1000),
                   "misfit table C: 59,319 runs x 1,000 grid points, 474.6 MB; library outputs: 949.1 kB in memory")
  expect_match(memory_statement(lib, 1, "thesis"),
               "59,319 runs x 1 grid point, 474.6 kB \\(and its run order for the thesis update, 237.3 kB\\)")
})

test_that("a library on disk says so", {
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(sim_library(data.frame(k = 1:20), matrix(stats::rnorm(40), 20, 2)), dir,
                   chunk_size = 10)
  expect_match(memory_statement(disk_library(dir, trust = TRUE), 3), "library outputs: 320 B on disk$")
})

test_that("print() of a fit states the memory, and a large precompute announces it", {
  ex <- griddy_example()
  fit <- suppressWarnings(calibrate(ex$library, ex$field, n_iter = 200, burn_in = 50, seed = 1))
  expect_output(print(fit), paste0("Memory: misfit table C: ", lib_n_runs(ex$library),
                                   " runs x 1 grid point, "), fixed = TRUE)
  expect_message(inform_memory(ex$library, 10, threshold = 0), class = "griddy_message_memory",
                 regexp = "Computing the misfit table C: .* x 10 grid points")
  expect_silent(inform_memory(ex$library, 10))
  # the up-front statement left out the thesis update's run order (4 GB at
  # 10^6 runs x 1,000 grid points), which print(fit) gave afterwards
  expect_message(inform_memory(ex$library, 10, "thesis", threshold = 0),
                 class = "griddy_message_memory", regexp = "its run order for the thesis update")
})

test_that("the path from the outputs to the posterior does not copy C", {
  skip_if_not(capabilities("profmem"), "R without memory profiling")
  # misfit_table() stripped an attribute C never had, which copied C
  C <- matrix(stats::runif(20), 10, 2)
  tracemem(C)
  expect_silent(out <- fold_extra_logdet(C, thesis_prior(), 5))
  untracemem(C)
  ex <- griddy_example()
  problem <- local_problem(ex$library, ex$field)
  tracemem(problem$C)
  expect_silent({
    tables <- sampler_tables(problem, "collapsed")
    exact <- exact_from_problem(problem, joint = FALSE)
    fit <- sample_problem(problem, "collapsed", sampler_control(100, 10, 1, 1, FALSE), 1,
                          quote(calibrate()))
  })
  untracemem(problem$C)
})
