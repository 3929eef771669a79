test_that("a cubic spline matrix interpolates every run at once, exactly at shared coordinates", {
  t_from <- seq(0, 2, by = 0.25)
  y <- rbind(sin(t_from), t_from^3, exp(-t_from))
  t_to <- c(0.1, 0.5, 1.3, 2)
  got <- interpolate_outputs(y, t_from, t_to)
  want <- t(apply(y, 1, function(r) stats::splinefun(t_from, r, method = "fmm")(t_to)))
  expect_equal(unclass(got)[, ], want, tolerance = 1e-12, ignore_attr = TRUE)
  expect_equal(got[, 2], y[, 3], tolerance = 1e-12)  # 0.5 is a coordinate of the runs
  expect_equal(got[2, ], t_to^3, tolerance = 1e-10)  # a cubic is reproduced
  expect_lt(max(abs(got[1, ] - sin(t_to))), 1e-3)
})

test_that("blocks are interpolated one by one, and the leave-one-out error is measured", {
  t_from <- 1:5
  y <- cbind(matrix(1:5, 1), matrix((1:5)^2, 1))  # two x blocks
  got <- interpolate_outputs(y, t_from, c(1.5, 4.5), n_blocks = 2)
  expect_equal(as.vector(got), c(1.5, 4.5, 2.25, 20.25), tolerance = 1e-12,
               ignore_attr = TRUE)
  expect_equal(attr(got, "loo_rms"), 0, tolerance = 1e-12)  # polynomials of degree <= 3
  wiggly <- interpolate_outputs(matrix(sin(3 * t_from), 1), t_from, 2.5)
  expect_gt(attr(wiggly, "loo_rms"), 0.05)
  expect_true(is.na(attr(interpolate_outputs(matrix(1:2, 1), 1:2, 1.5), "loo_rms")))
})

test_that("coordinates outside the runs' range are refused rather than extrapolated", {
  expect_error(interpolate_outputs(matrix(1:3, 1), 1:3, c(0.5, 2)), "0.5 lie outside",
               class = "griddy_error_input")
  expect_error(assert_output_coordinates(c(2, 1), "t_field"), "strictly increasing")
  expect_null(assert_output_coordinates(NULL, "t_field"))
})
