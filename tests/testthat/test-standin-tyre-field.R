test_that("tyre_field_data is the model at the truth plus noise, shaped like the library", {
  rig <- tyre_rig(n_samples = 100)
  f <- tyre_field_data(height = c(27.44, 12.13), noise_sd = 60, seed = 3, rig = rig)
  expect_s3_class(f, "griddy_field")
  expect_equal(dim(f$y), c(2L, 100L))
  expect_equal(f$x, data.frame(height = c(27.44, 12.13)))
  expect_equal(f$t, seq_len(100) / 1000)
  expect_equal(attr(f, "truth"), c(k = 450, c = 1.5))
  clean <- tyre_cleat_model(450, 1.5, height = c(27.44, 12.13), rig = rig)
  expect_equal(attr(f, "clean")[1, ], unname(clean[1, 1:100]))
  expect_equal(attr(f, "clean")[2, ], unname(clean[1, 101:200]))
  expect_equal(f$y, attr(f, "clean") + attr(f, "noise"))
  expect_lt(abs(sd(as.vector(attr(f, "noise"))) / 60 - 1), 0.2)
  # the data line up with a library on the same heights and rig
  set.seed(1)
  lib <- tyre_library(5, height = c(27.44, 12.13), rig = rig)
  expect_equal(length(griddy:::field_vector(lib, f)), 200L)
})

test_that("tyre_field_data is reproducible from its seed and leaves the stream alone", {
  set.seed(9)
  a <- stats::runif(1)
  set.seed(9)
  f1 <- tyre_field_data(height = 12.13, seed = 42)
  expect_identical(stats::runif(1), a)
  f2 <- tyre_field_data(height = 12.13, seed = 42)
  expect_identical(f1, f2)
  expect_false(identical(f1$y, tyre_field_data(height = 12.13, seed = 43)$y))
  # no noise: exactly the model
  f0 <- tyre_field_data(height = 12.13, noise_sd = 0)
  expect_equal(f0$y[1, ], unname(tyre_cleat_model(450, 1.5, height = 12.13)[1, ]))
})

test_that("tyre_field_data passes the model choice through", {
  fp <- tyre_field_data(height = 27.44, model = "pac2002", noise_sd = 0)
  expect_identical(attr(fp, "model"), "pac2002")
  expect_equal(fp$y[1, ], unname(tyre_cleat_model(450, 1.5, height = 27.44,
                                                 model = "pac2002")[1, ]))
  ff <- tyre_field_data(height = 27.44, noise_sd = 0)
  expect_gt(max(abs(fp$y - ff$y)), 100)
})

test_that("tyre_field_data validates its inputs", {
  expect_error(tyre_field_data(k = c(1, 2)), "`k` must be 1 finite number")
  expect_error(tyre_field_data(c = -1), "`c` must be")
  expect_error(tyre_field_data(noise_sd = -1), "`noise_sd` must be")
  expect_error(tyre_field_data(model = "swift"), "`model` must be one of", class = "griddy_error_input")
  expect_error(tyre_field_data(seed = NA), "`seed` must be", class = "griddy_error_input")
  expect_error(tyre_field_data(height = 27.44, hight = 12), "may be speed, camber, pressure, pac, rig; received hight",
               class = "griddy_error_input")
})
