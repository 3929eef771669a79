test_that("piston_library builds a full-factorial sim_library", {
  lib <- piston_library(3)
  expect_s3_class(lib, "sim_library")
  expect_identical(names(lib$theta), c("htc_undercrown", "htc_gallery1", "htc_gallery2"))
  expect_identical(nrow(lib$theta), 27L)
  expect_identical(dim(lib$y), c(27L, 27L))
  expect_identical(names(lib$x), c("r", "z"))
  expect_identical(nrow(lib$x), 27L)
  expect_lte(length(lib$t), 1L)                    # one output per x setting
  rng <- piston_htc_ranges()
  for (j in 1:3) {
    expect_equal(sort(unique(lib$theta[[j]])), c(rng$min[j], (rng$min[j] + rng$max[j]) / 2, rng$max[j]))
  }
  # rows are piston_model() at the theta rows
  i <- c(1, 14, 27)
  expect_equal(unname(lib$y[i, ]), unname(piston_model(as.matrix(lib$theta[i, ]))))
  # x are the scaled location coordinates
  loc <- piston_locations()
  expect_equal(lib$x$r, loc$r)
  expect_equal(lib$x$z, loc$z)
})

test_that("piston_library subsets locations and adds operating conditions", {
  for (n in c(2, 5)) {
    lib <- piston_library(3, locations = piston_location_ids(n))
    expect_equal(dim(lib$y), c(27, 3 * n))
    expect_equal(nrow(lib$x), 3 * n)
  }
  lib54 <- piston_library(3, condition = c("full", "part"))
  expect_identical(dim(lib54$y), c(27L, 54L))
  expect_identical(names(lib54$x), c("r", "z", "condition"))
  expect_identical(lib54$x$condition, rep(c(1, 2), each = 27))
  # the part-load block is cooler than the full-load block
  expect_true(all(lib54$y[, 28:54] < lib54$y[, 1:27]))
})

test_that("piston_library sizes and spacing", {
  lib <- piston_library(4, locations = piston_location_ids(1), spacing = "log")
  expect_identical(nrow(lib$theta), 64L)
  g <- sort(unique(lib$theta$htc_undercrown))
  expect_equal(diff(log(g)), rep(diff(log(g))[1], 3))
  expect_error(piston_library(1), "`n_per_dim` must be a single whole number in 2..60; received 1",
               class = "griddy_error_input")
  expect_error(piston_library(3.5), "`n_per_dim` must be", class = "griddy_error_input")
  expect_error(piston_library(2^31), "`n_per_dim` must be", class = "griddy_error_input")
  expect_error(piston_library(3, condition = "idle"), "`condition` must be",
               class = "griddy_error_input")
  expect_error(piston_library(3, spacing = "cubic"), "`spacing` must be one of \"linear\", \"log\"",
               class = "griddy_error_input")
})

test_that("piston_library passes on only the piston_model() arguments it does not set", {
  expect_error(piston_library(3, materal = "aluminium"),
               "`...`\\) to piston_model\\(\\) may be material, cell, gallery_gradient, conductivity_slope; received materal",
               class = "griddy_error_input")
  expect_error(piston_library(3, htc = 1), "received htc", class = "griddy_error_input")
  expect_error(piston_library(3, 1:3, "full", "linear", "steel"), "must be named",
               class = "griddy_error_input")
  lib <- piston_library(2, locations = 1, material = "aluminium")
  expect_equal(unname(lib$y[1, ]),
               unname(piston_model(unlist(lib$theta[1, ]), locations = 1, material = "aluminium")[1, ]))
})
