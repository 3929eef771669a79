test_that("design_lhs() puts one run in each slice of every range, reproducibly", {
  d <- design_lhs(10, k = c(1, 4), c = c(0, 0.5), seed = 1)
  expect_named(d, c("k", "c"))
  expect_equal(nrow(d), 10L)
  expect_equal(sort(floor((d$k - 1) / 0.3)), 0:9)
  expect_equal(sort(floor(d$c / 0.05)), 0:9)
  expect_identical(design_lhs(10, k = c(1, 4), c = c(0, 0.5), seed = 1), d)
  expect_false(identical(design_lhs(10, k = c(1, 4), c = c(0, 0.5), seed = 2), d))
})

test_that("design_grid() is the full factorial, the first parameter fastest", {
  g <- design_grid(k = 1:3, c = c(0, 0.5))
  expect_equal(nrow(g), 6L)
  expect_equal(g$k, rep(1:3, 2))
  expect_equal(g$c, rep(c(0, 0.5), each = 3))
})

test_that("designs refuse unnamed or bad ranges", {
  expect_error(design_lhs(5, c(1, 4)), class = "griddy_error_input")
  expect_error(design_lhs(5, k = c(4, 1)), class = "griddy_error_input")
  expect_error(design_grid(k = c(1, 1)), class = "griddy_error_input")
  expect_error(design_grid(), class = "griddy_error_input")
})
