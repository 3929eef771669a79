test_that("refine() runs the simulator on the workers of a future plan, same result", {
  skip_if_not_installed("future.apply")
  skip_on_cran()
  skip_if_not(installed_griddy_is_current("run_chunks"), "the installed griddy is not this version")
  toy <- refine_toy()
  # a simulator as a user defines it, in the global environment: one defined
  # in the test's environment drags the attached package's environment to
  # the workers ("'package:griddy' may not be available when loading")
  sim <- refine_sim
  environment(sim) <- globalenv()
  # 60 runs do not resolve the toy: the warning says so, the same both ways
  expect_warning(sequential <- refine(toy$fit, sim, max_runs = 60, runs_per_round = 30, seed = 4),
                 class = "griddy_warning_resolution")
  future::plan("multisession", workers = 2)
  on.exit(future::plan("sequential"), add = TRUE)
  expect_warning(parallel <- refine(toy$fit, sim, max_runs = 60, runs_per_round = 30, seed = 4),
                 class = "griddy_warning_resolution")
  expect_identical(lib_theta(parallel$library), lib_theta(sequential$library))
  expect_equal(parallel$C, sequential$C)
})

test_that("one run is one chunk", {
  expect_equal(simulator_chunks(1L), list(1L))
  expect_equal(unlist(simulator_chunks(25L)), 1:25)
  expect_length(simulator_chunks(25L), 10L)
})

test_that("a round whose simulator fails on some rows keeps the rows that finished, names the rest", {
  toy <- refine_toy()
  calls <- 0L
  simulated <- 0L
  # from the second round on, runs whose 4th decimal of k is a multiple of 3 fail
  sim <- function(theta) {
    calls <<- calls + 1L
    bad <- calls > 10L & floor(theta$k * 1e4) %% 3 == 0
    if (any(bad)) stop("diverged at k = ", theta$k[bad][1])
    simulated <<- simulated + nrow(theta)
    refine_sim(theta)
  }
  e <- tryCatch(refine(toy$fit, sim, max_runs = 400, runs_per_round = 30, seed = 1),
                error = function(e) e)
  expect_s3_class(e, "griddy_error_simulator")
  n <- vapply(lib_rounds(e$fit$library), `[[`, integer(1), "n")
  expect_equal(n[1], 30L)
  expect_gt(n[2], 0L)
  expect_lt(n[2], 30L)
  # every run simulated is in the fit, and every run of the round accounted for
  expect_equal(lib_n_runs(e$fit$library) - lib_n_runs(toy$lib), simulated)
  failed <- as.integer(sub(".*failed on ([0-9]+) run.*", "\\1", conditionMessage(e$parent)))
  expect_equal(n[2] + failed, 30L)
  expect_match(conditionMessage(e$parent), "diverged at k = ")
})
