# The stream's construction and its data.

test_that("a dense rho_x and bad measurements are refused", {
  ex <- griddy_example()
  expect_error(griddy_stream(ex$library, rho_x = c(0, 0.5)),
               class = "griddy_error_unsupported")
  s <- griddy_stream(ex$library)
  expect_error(update(s, y = 1, t = ex$library$t[1]), class = "griddy_error_shape")
  expect_error(update(s, y = 1, x = data.frame(mass = 3), t = ex$library$t[1]),
               class = "griddy_error_input")
  expect_error(update(s, y = 1:2, x = ex$field$x[1, , drop = FALSE], t = 0),
               class = "griddy_error_shape")
  expect_error(posterior_exact(s), class = "griddy_error_input")
  expect_equal(nobs(s), 0L)
})

test_that("stream_data() holds the data in arrival order", {
  ex <- griddy_example()
  s <- griddy_stream(ex$library)
  update(s, y = c(5, 6), x = ex$field$x[c(3, 1), , drop = FALSE], t = ex$library$t[c(2, 4)])
  d <- stream_data(s)
  expect_equal(d$y, c(5, 6))
  expect_equal(d$mass, ex$field$x$mass[c(3, 1)])
  expect_equal(d$t, ex$library$t[c(2, 4)])
})

test_that("a library of emulated runs is refused", {
  skip_if_not_installed("RobustGaSP")
  expect_error(griddy_stream(emulated_toy_library(n_runs = 200)),
               class = "griddy_error_unsupported")
})
