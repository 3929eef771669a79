test_that("run weights are normalised and validated", {
  expect_equal(exp(log_run_weights(NULL, 4)), rep(0.25, 4))
  expect_equal(exp(log_run_weights(c(1, 3), 2)), c(0.25, 0.75))
  expect_error(log_run_weights(1:3, 2), "one weight per library run \\(2\\); received 3")
  expect_error(log_run_weights(c(-1, 2), 2), ">= 0 with a positive sum")
})

test_that("an exact reproduction with a zero prior rate is refused", {
  lib <- sim_library(data.frame(k = 1:3), matrix(c(1, 2, 3, 4, 5, 6), 3))
  f <- field_data(c(2, 5))
  expect_error(calibration_problem(lib, f, 0, 0, list(shape = 1, rate = 0), 2, NULL),
               "reproduces the field data exactly")
  expect_silent(calibration_problem(lib, f, 0, 0, list(shape = 1, rate = 1e-9), 2, NULL))
})

test_that("log_sum_exp is stable", {
  expect_equal(log_sum_exp(c(-1000, -1000)), -1000 + log(2))
  expect_equal(log_sum_exp(c(800, 0)), 800)
})
