test_that("tyre_library draws a reproducible Latin hypercube and wraps it in a sim_library", {
  set.seed(11)
  lib <- tyre_library(10, height = c(27.44, 12.13))
  set.seed(11)
  lib2 <- tyre_library(10, height = c(27.44, 12.13))
  expect_identical(lib, lib2)
  expect_s3_class(lib, "sim_library")
  expect_identical(names(lib$theta), c("k", "c"))
  expect_equal(dim(lib$y), c(10, 1000))
  expect_equal(lib$x$height, c(27.44, 12.13))
  expect_equal(lib$t, seq_len(500) / 1000)
  # one point in each of the 10 strata of each parameter
  expect_setequal(floor((lib$theta$k - 50) / 75), 0:9)
  expect_setequal(floor(lib$theta$c / 0.5), 0:9)
  expect_equal(unname(lib$y[3, ]),
               unname(as.vector(tyre_cleat_model(lib$theta$k[3], lib$theta$c[3],
                                                 height = c(27.44, 12.13)))))
  expect_error(tyre_library(1), "`n_runs` must be a single whole number >= 2; received 1",
               class = "griddy_error_input")
  expect_error(tyre_library(2^31), "`n_runs` must be", class = "griddy_error_input")
})

test_that("tyre_library checks its ranges and what it passes on", {
  r <- tyre_param_ranges()
  expect_error(tyre_library(5, ranges = r[1, ]), "`ranges` must be a data.frame like tyre_param_ranges\\(\\)",
               class = "griddy_error_input")
  expect_error(tyre_library(5, ranges = rbind(r, r)), "`ranges` has more than one row for k, c",
               class = "griddy_error_input")
  bad <- r
  bad$max[1] <- 10
  expect_error(tyre_library(5, ranges = bad), "`ranges` must have finite min < max", class = "griddy_error_input")
  bad <- r
  bad$min <- as.character(bad$min)
  expect_error(tyre_library(5, ranges = bad), "`ranges\\$min` must be", class = "griddy_error_input")
  expect_error(tyre_library(5, sped = 10), "to tyre_cleat_model\\(\\) may be .*; received sped",
               class = "griddy_error_input")
  expect_error(tyre_library(5, k = 10), "received k", class = "griddy_error_input")
})
