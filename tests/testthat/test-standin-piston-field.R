test_that("piston_field_data matches piston_library's settings for each data size", {
  for (n in c(6, 15, 27, 54)) {
    f <- piston_field_data(n, seed = 1)
    expect_s3_class(f, "griddy_field")
    expect_length(f$y, n)
    lib <- piston_library(3, locations = attr(f, "locations"), condition = attr(f, "condition"))
    expect_equal(f$x, lib$x)
    expect_equal(attr(f, "clean"),
                 unname(drop(piston_model(c(1000, 3000, 2000), attr(f, "locations"),
                                          attr(f, "condition")))))
  }
})

test_that("data sizes are nested draws of one campaign and seeds reproduce", {
  f54 <- piston_field_data(54, discrepancy = TRUE, seed = 7)
  f6 <- piston_field_data(6, discrepancy = TRUE, seed = 7)
  ids <- attr(f6, "locations")
  expect_equal(attr(f6, "noise"), attr(f54, "noise")[ids])
  expect_equal(attr(f6, "discrepancy"), attr(f54, "discrepancy")[ids])
  expect_identical(piston_field_data(15, seed = 2)$y, piston_field_data(15, seed = 2)$y)
  expect_false(identical(piston_field_data(15, seed = 2)$y, piston_field_data(15, seed = 3)$y))
  expect_equal(attr(piston_field_data(27, seed = 7), "discrepancy"), rep(0, 27))
})

test_that("noise and discrepancy have the thesis's scale and correlation", {
  d <- replicate(400, attr(piston_field_data(54, TRUE, seed = NULL), "discrepancy"))
  n <- replicate(400, attr(piston_field_data(54, FALSE, seed = NULL), "noise"))
  expect_equal(mean(apply(d, 1, var)), 40, tolerance = 0.15)
  expect_equal(mean(apply(n, 1, var)), 0.4, tolerance = 0.15)
  # neighbouring locations on a surface are strongly correlated
  expect_gt(cor(d[1, ], d[2, ]), 0.8)
})

test_that("piston_field_data rejects bad input", {
  expect_error(piston_field_data(10), "`n_points` must be one of 6, 15, 27, 54; received 10",
               class = "griddy_error_input")
  expect_error(piston_field_data(6, truth = c(1, 2)), "`truth` must be 3 finite numbers in \\(0, Inf\\]",
               class = "griddy_error_input")
  expect_error(piston_field_data(6, truth = c(1, -2, 3)), "`truth`", class = "griddy_error_input")
  expect_error(piston_field_data(6, seed = "a"), "`seed` must be a single whole number",
               class = "griddy_error_input")
  expect_error(piston_field_data(6, seed = 2^31), "`seed`", class = "griddy_error_input")
  expect_error(piston_field_data(6, noise_var = -1), "noise_var")
  expect_error(piston_field_data(6, rho = 1), "rho")
  expect_error(piston_field_data(6, discrepancy = NA), "discrepancy")
})

test_that("a calibration on the piston recovers the truth within one library step", {
  set.seed(11)
  f <- piston_field_data(27, seed = 11)
  lib <- piston_library(9, locations = attr(f, "locations"))
  # 27 precise points on a coarse grid: one run may hold nearly all the mass
  fit <- suppressWarnings(calibrate(lib, f, n_iter = 3000, burn_in = 1000, seed = 11))
  s <- summary(fit)
  rng <- piston_htc_ranges()
  step <- (rng$max - rng$min) / 8
  est <- s$median[match(rng$parameter, s$parameter)]
  expect_true(all(abs(est - c(1000, 3000, 2000)) <= step))
})

test_that("zero variances give data without that error term", {
  f <- piston_field_data(6, discrepancy = TRUE, discrepancy_var = 0, seed = 1)
  expect_identical(attr(f, "discrepancy"), numeric(6))
  g <- piston_field_data(6, noise_var = 0, seed = 1)
  expect_identical(attr(g, "noise"), numeric(6))
  expect_equal(as.vector(t(g$y)), attr(g, "clean"))
})
