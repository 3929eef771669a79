test_that("the example library loads and its truth is inside the library's range", {
  ex <- griddy_example()
  expect_s3_class(ex$library, "sim_library")
  expect_s3_class(ex$field, "griddy_field")
  expect_identical(dim(ex$library$y), c(441L, 90L))
  expect_identical(names(ex$truth), c("k", "c"))
  expect_true(all(ex$truth >= vapply(ex$library$theta, min, 0) &
                    ex$truth <= vapply(ex$library$theta, max, 0)))
  fit <- suppressWarnings(
    calibrate(ex$library, ex$field, n_iter = 3000, burn_in = 500, seed = 1),
    classes = "griddy_warning_resolution")
  s <- summary(fit)
  # the truth lies off the grid; the interval must reach the grid points around it
  k <- s[s$parameter == "k", ]
  expect_true(k$lower <= 1250 && k$upper >= 1175)
})
