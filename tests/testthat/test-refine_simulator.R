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
  sequential <- refine(toy$fit, sim, max_runs = 200, seed = 4)
  future::plan("multisession", workers = 2)
  on.exit(future::plan("sequential"), add = TRUE)
  parallel <- refine(toy$fit, sim, max_runs = 200, seed = 4)
  expect_identical(lib_theta(parallel$library), lib_theta(sequential$library))
  expect_equal(parallel$C, sequential$C)
})

test_that("one run is one chunk", {
  expect_equal(simulator_chunks(1L), list(1L))
  expect_equal(unlist(simulator_chunks(25L)), 1:25)
  expect_length(simulator_chunks(25L), 10L)
})
