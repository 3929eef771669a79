# plot() of a stream and of a model choice: the ggplot's layers and data
# (no image comparison: vdiffr is not a dependency).

test_that("plot() of a stream draws the exact posterior margins of theta (issue 32)", {
  ex <- griddy_example()
  s <- update(griddy_stream(ex$library), y = ex$field)
  p <- plot(s)
  expect_s3_class(p, "ggplot")
  expect_s3_class(p$layers[[1]]$geom, "GeomRect")
  d <- p$data
  expect_setequal(levels(d$parameter), names(ex$library$theta))
  # each panel's bars are the exact run probabilities summed by library value
  run <- posterior_exact(s, joint = FALSE)$run
  k <- d[d$parameter == "k", ]
  expect_equal(k$prob, as.vector(tapply(run, ex$library$theta$k, sum)), tolerance = 1e-12)
  expect_equal(k$value, sort(unique(ex$library$theta$k)))
  expect_match(p$labels$title, "after 90 measurement")
  # before any measurement: the prior
  p0 <- plot(griddy_stream(ex$library))
  expect_match(p0$labels$title, "Prior")
  expect_equal(sum(p0$data$prob[p0$data$parameter == "c"]), 1)
})

test_that("plot() of a stream over a scattered design draws weighted densities", {
  set.seed(4)
  theta <- data.frame(a = runif(500), b = runif(500))
  tt <- seq(0, 1, length.out = 6)
  lib <- sim_library(theta, outer(theta$a, tt) + outer(theta$b, tt^2), t = tt)
  s <- update(griddy_stream(lib), y = 0.4 * tt + 0.7 * tt^2, t = tt)
  p <- plot(s)
  expect_s3_class(p$layers[[1]]$geom, "GeomArea")
  expect_setequal(levels(p$data$parameter), c("a", "b"))
  expect_true(all(p$data$density >= 0))
  # the density of a sits near the truth 0.4
  a <- p$data[p$data$parameter == "a", ]
  expect_lt(abs(a$value[which.max(a$density)] - 0.4), 0.1)
})

test_that("plot() of stream_models() draws the probabilities as the data arrived (issue 32)", {
  ex <- griddy_example()
  rival <- sim_library(ex$library$theta, 0.9 * ex$library$y, x = ex$library$x,
                       t = ex$library$t)
  m <- stream_models(spring = griddy_stream(ex$library), damped = griddy_stream(rival),
                     prior = c(1, 3))
  p0 <- plot(m)
  expect_s3_class(p0$layers[[1]]$geom, "GeomCol")
  expect_equal(p0$data$prob, c(0.25, 0.75))
  update(m, y = ex$field)
  p <- plot(m)
  expect_s3_class(p, "ggplot")
  expect_s3_class(p$layers[[1]]$geom, "GeomStep")
  h <- as.data.frame(m)
  d <- p$data
  # step 0 is the prior, then one point per measurement and model
  expect_identical(nrow(d), 2L * (nrow(h) + 1L))
  expect_equal(d$prob[d$model == "spring" & d$step == 0], 0.25)
  expect_equal(d$prob[d$model == "damped" & d$step > 0], h$prob_damped)
  expect_identical(levels(d$model), c("spring", "damped"))
})

test_that("plot(stream, \"ppc\") draws its predictions, at new settings too", {
  x <- data.frame(x = seq(0.2, 4, length.out = 6))
  theta <- data.frame(theta = seq(0.3, 1, by = 0.005))
  lib <- sim_library(theta, outer(theta$theta, x$x), x = x)
  set.seed(1)
  s <- update(griddy_stream(lib), y = field_data(matrix(0.65 * x$x + stats::rnorm(6, sd = 0.05)),
                                                 x = x))
  pp <- plot(s, "ppc", ndraws = 200, seed = 1)
  expect_identical(pp$data$position, x$x)
  expect_equal(pp$data$mean, predict(s, ndraws = 200, seed = 1)$mean)
  simulator <- function(theta, x) outer(theta$theta, x$x)
  pn <- plot(s, "ppc", newdata = data.frame(x = 6), simulator = simulator, ndraws = 200,
             seed = 1)
  expect_identical(pn$data$position, c(x$x, 6))
  expect_identical(pn$data$new, rep(c(FALSE, TRUE), c(6, 1)))
  expect_s3_class(ggplot2::ggplot_build(pn), "ggplot_built")
  expect_error(plot(s, "ppc", newdata = data.frame(x = 6)), class = "griddy_error_prediction")
  expect_error(plot(s, "trace"), class = "griddy_error_input")
})
