test_that("each plot type returns a ggplot built from the fit", {
  toy <- toy_xt(n_per_dim = 5, n_t = 6)
  fit <- suppressWarnings(
    calibrate(toy$library, toy$field, rho_t = c(0, 0.3), n_iter = 600, burn_in = 100,
              chains = 2, seed = 1),
    classes = "griddy_warning_resolution")
  tr <- plot(fit)
  expect_s3_class(tr, "ggplot")
  expect_identical(levels(tr$data$parameter), c("a", "b", "tau", "rho_t"))
  po <- plot(fit, "posterior", truth = c(a = 1.5, b = 0.4))
  expect_s3_class(po, "ggplot")
  bars <- po$data
  expect_equal(sum(bars$prob[bars$parameter == "a"]), 1)
  expect_true(all(bars$value[bars$parameter == "b"] %in% toy$library$theta$b))
  expect_s3_class(ggplot2::ggplot_build(po), "ggplot_built")
  pp <- plot(fit, "ppc", ndraws = 100, seed = 1)
  expect_s3_class(pp, "ggplot")
  expect_identical(levels(pp$data$setting), c("load = 1, speed = 10", "load = 2, speed = 10",
                                              "load = 3, speed = 20"))
  expect_s3_class(ggplot2::ggplot_build(pp), "ggplot_built")
  expect_error(plot(fit, "posterior", truth = c(z = 1)), "`truth` must be named by theta columns")
  expect_error(plot(fit, "density"), class = "griddy_error_input", regexp = "`type` must be one of")
})

test_that("the ppc plot leaves missing field cells out without a warning", {
  toy <- toy_missing()
  fit <- suppressWarnings(calibrate(toy$library, toy$field, n_iter = 300, burn_in = 50, seed = 1))
  pp <- plot(fit, "ppc", ndraws = 50, seed = 1)
  expect_equal(sum(is.na(pp$data$observed)), 4)
  expect_no_warning(ggplot2::ggplotGrob(pp))
  expect_match(pp$labels$subtitle, "\n", fixed = TRUE)
})

test_that("the ppc plot handles one output per setting", {
  lib <- sim_library(data.frame(k = 1:5), outer(1:5, 1:4), x = data.frame(pos = 1:4))
  fit <- suppressWarnings(calibrate(lib, field_data(c(2.1, 3.9, 6.2, 7.8)), n_iter = 300,
                                   burn_in = 50, seed = 1))
  pp <- plot(fit, "ppc", ndraws = 50, seed = 1)
  expect_identical(pp$data$position, as.numeric(lib$x$pos))
  expect_identical(pp$labels$x, "pos")
  expect_s3_class(ggplot2::ggplot_build(pp), "ggplot_built")
})

test_that("the posterior of a refined fit is a density over its weighted runs", {
  toy <- refine_toy()
  refined <- refine(toy$fit, refine_sim, max_runs = 2000, seed = 1)
  p <- plot(refined, "posterior", truth = c(k = toy$k))
  expect_s3_class(p, "ggplot")
  expect_true(any(vapply(p$layers, function(l) inherits(l$geom, "GeomArea"), logical(1))))
  expect_silent(ggplot2::ggplot_build(p))
})

test_that("the posterior of a scattered design is a density, of a grid bars", {
  # an emulated library's 10,000 distinct values made bars one run wide
  set.seed(1)
  n <- 400
  theta <- data.frame(k = (sample(n) - stats::runif(n)) / n, c = (sample(n) - stats::runif(n)) / n)
  t <- seq(0, 1, length.out = 8)
  sim <- function(th) outer(th$k, t) + outer(th$c, t^2)
  field <- field_data(drop(sim(data.frame(k = 0.4, c = 0.6))) + stats::rnorm(8, sd = 0.05),
                      t = t)
  lhs <- sim_library(theta, sim(theta), t = t)
  fit <- suppressWarnings(calibrate(lhs, field, n_iter = 500, burn_in = 100, seed = 1))
  p <- plot(fit, "posterior")
  expect_true(any(vapply(p$layers, function(l) inherits(l$geom, "GeomArea"), logical(1))))
  grid <- expand.grid(k = seq(0, 1, length.out = 20), c = seq(0, 1, length.out = 20))
  fit_grid <- suppressWarnings(calibrate(sim_library(grid, sim(grid), t = t), field,
                                         n_iter = 500, burn_in = 100, seed = 1))
  expect_false(any(vapply(plot(fit_grid, "posterior")$layers,
                          function(l) inherits(l$geom, "GeomArea"), logical(1))))
})

test_that("a scattered design's posterior is smoothed for its effective runs, not spiky", {
  # 10,000 Latin-hypercube runs, a resolved fit on about 20 effective runs:
  # a histogram of the draws showed those runs as spikes, with false modes
  set.seed(1)
  n <- 10000
  theta <- data.frame(k = (sample(n) - stats::runif(n)) / n, c = (sample(n) - stats::runif(n)) / n)
  t <- seq(0, 1, length.out = 8)
  sim <- function(th) outer(th$k, t) + outer(th$c, t^2)
  field <- field_data(drop(sim(data.frame(k = 0.4, c = 0.6))) + stats::rnorm(8, sd = 0.02),
                      t = t)
  fit <- suppressWarnings(calibrate(sim_library(theta, sim(theta), t = t), field,
                                    n_iter = 2000, burn_in = 200, seed = 1))
  w <- posterior_exact(fit$library, field)$run
  n_eff <- 1 / sum(w^2)
  expect_lt(n_eff, 60)
  p <- plot(fit, "posterior")
  expect_match(p$labels$subtitle, paste0("smoothed for ", format(n_eff, digits = 3),
                                         " effective runs"), fixed = TRUE)
  for (par in c("k", "c")) {
    d <- p$data[p$data$parameter == par, ]
    # a density: it integrates to about 1 over the range drawn
    expect_equal(sum(diff(d$value) * (head(d$density, -1) + tail(d$density, -1)) / 2), 1,
                 tolerance = 0.02)
    # one mode, where the runs' weights put their mass
    modes <- sum(diff(sign(diff(d$density))) == -2)
    expect_identical(modes, 1L)
    mean_w <- sum(w * theta[[par]])
    expect_lt(abs(d$value[which.max(d$density)] - mean_w), 0.1)
    # the same density as stats::density() at Silverman's bandwidth for n_eff
    ref <- weighted_density(theta[[par]], w, n_eff)
    expect_equal(d$density, ref$y)
  }
})

test_that("the posterior and pairs plots leave room for the last tick label", {
  ex <- griddy_example()
  fit <- without_resolution_warning(
    calibrate(ex$library, ex$field, n_iter = 600, burn_in = 100, seed = 1))
  # the right margin held half a tick label ("1400" was cut at the edge)
  right <- function(p) as.numeric(ggplot2::ggplot_build(p)$plot$theme$plot.margin)[2]
  expect_gte(right(plot(fit, "posterior")), 16)
  expect_gte(right(plot(fit, "pairs")), 16)
})

test_that("traces are thinned for display and say so", {
  # 4 x 20,000 draws drew as a solid block and took seconds to save
  ex <- griddy_example()
  fit <- without_resolution_warning(
    calibrate(ex$library, ex$field, n_iter = 6000, burn_in = 1000, chains = 2, seed = 1))
  tr <- plot(fit, max_points = 500)
  per_chain <- table(tr$data$chain) / nlevels(tr$data$parameter)
  expect_true(all(per_chain <= 500))
  expect_match(tr$labels$subtitle, "One kept draw in 10 shown")
  expect_null(plot(fit, max_points = 5000)$labels$subtitle)
})

test_that("the predictive check's subtitle follows `level`", {
  ex <- griddy_example()
  fit <- without_resolution_warning(
    calibrate(ex$library, ex$field, n_iter = 600, burn_in = 100, seed = 1))
  expect_match(plot(fit, "ppc", level = 0.8, ndraws = 50, seed = 1)$labels$subtitle, "80% band")
  expect_match(plot(fit, "ppc", ndraws = 50, seed = 1)$labels$subtitle, "95% band")
})

test_that("the pairs plot shows every pair of theta columns, the truth marked", {
  ex <- griddy_example()
  fit <- without_resolution_warning(
    calibrate(ex$library, ex$field, n_iter = 600, burn_in = 100, seed = 1))
  p <- plot(fit, "pairs", truth = ex$truth)
  expect_s3_class(p, "ggplot")
  pairs <- as.vector(utils::combn(names(ex$library$theta), 2L,
                                  function(pr) paste0(pr[1], " (x), ", pr[2], " (y)")))
  expect_identical(levels(p$data$pair), pairs)
  expect_equal(nrow(p$data), length(pairs) * nrow(fit$draws))
  expect_silent(ggplot2::ggplot_build(p))
  # one pair: the axes are titled by the parameters ("Value (x)" before)
  expect_identical(c(p$labels$x, p$labels$y), c("k", "c"))
  one <- sim_library(data.frame(k = 1:5), outer(1:5, 1:4))
  fit1 <- suppressWarnings(calibrate(one, field_data(c(1, 2, 3, 4.1)), n_iter = 300,
                                     burn_in = 50, seed = 1))
  expect_error(plot(fit1, "pairs"), "at least two theta columns", class = "griddy_error_input")
})

# The width, in inches, of each line of a plot's subtitle at its theme's size.
subtitle_inches <- function(p) {
  size <- ggplot2::calc_element("plot.subtitle", p$theme)$size
  grDevices::pdf(NULL)
  on.exit(grDevices::dev.off())
  vapply(strsplit(p$labels$subtitle, "\n", fixed = TRUE)[[1]], function(line) {
    grob <- grid::textGrob(line, gp = grid::gpar(fontsize = size))
    grid::convertWidth(grid::grobWidth(grob), "inches", valueOnly = TRUE)
  }, numeric(1))
}

test_that("the subtitles of a discrepancy fit's plots fit a 6-inch figure", {
  fit <- bump_fit(bump_sys(reps = 2))
  # the longest: "+ discrepancy" in the ppc, the replicates' means in the other
  ppc <- plot(fit, "ppc", ndraws = 50, seed = 1, level = 0.95)
  disc <- plot(fit, "discrepancy", ndraws = 50, seed = 1)
  expect_match(ppc$labels$subtitle, "+ discrepancy", fixed = TRUE)
  expect_match(disc$labels$subtitle, "replicates' means", fixed = TRUE)
  # a y axis of about 0.6 inches beside the text leaves 5.4 of the 6
  expect_lt(max(subtitle_inches(ppc)), 5)
  expect_lt(max(subtitle_inches(disc)), 5)
  expect_identical(wrap_subtitle(c("One.", "Two words.")), "One.\nTwo words.")
  expect_identical(wrap_subtitle("a b c", width = 1), "a\nb\nc")
})

test_that("the discrepancy plot shows delta's posterior and the residuals per setting", {
  sys <- bump_sys()
  fit <- bump_fit(sys)
  p <- plot(fit, "discrepancy", ndraws = 200, seed = 1)
  expect_s3_class(p, "ggplot")
  expect_equal(p$data$mean, discrepancy_posterior(fit, ndraws = 200, seed = 1)$mean)
  expect_equal(p$data$residual, fit$y_field - posterior_mean_outputs(fit))
  expect_identical(levels(p$data$setting), c("amp = 1", "amp = 2", "amp = 3"))
  expect_identical(p$data$position, discrepancy_posterior(fit, ndraws = 10)$t)
  expect_identical(p$labels$x, "t")
  expect_match(p$labels$subtitle, "\n", fixed = TRUE)
  expect_match(p$labels$title, "misses the data", fixed = TRUE)
  expect_match(p$labels$subtitle, "discrepancy's posterior mean", fixed = TRUE)
  expect_no_warning(ggplot2::ggplotGrob(p))
  expect_match(plot(fit, "ppc", ndraws = 50, seed = 1)$labels$subtitle, "+ discrepancy",
               fixed = TRUE)
  expect_no_match(plot(fit, "ppc", ndraws = 50, seed = 1, discrepancy = FALSE)$labels$subtitle,
                  "discrepancy", fixed = TRUE)
  plain <- suppressWarnings(calibrate(sys$library, sys$field, n_iter = 100, burn_in = 10,
                                      seed = 1))
  expect_error(plot(plain, "discrepancy"), class = "griddy_error_input",
               regexp = "has no discrepancy")
})

test_that("the discrepancy plot handles one output per setting", {
  lib <- sim_library(data.frame(k = seq(0.5, 1.5, by = 0.05)),
                     outer(seq(0.5, 1.5, by = 0.05), 1:6), x = data.frame(pos = 1:6))
  fit <- suppressWarnings(calibrate(lib, field_data(c(1, 2, 3.8, 4, 5, 6) + c(0, 0, 0.9, 0, 0, 0)),
                                    n_iter = 300, burn_in = 50, seed = 1,
                                    discrepancy = gp_discrepancy()))
  p <- plot(fit, "discrepancy", ndraws = 50, seed = 1)
  expect_identical(p$data$position, as.numeric(1:6))
  expect_identical(p$labels$x, "pos")
  expect_no_warning(ggplot2::ggplotGrob(p))
})

test_that("an x column named `x` plots: ppc and discrepancy panels titled by its values", {
  # predict() and discrepancy_posterior() gave two columns named `x`, which
  # ggplot refused ("`data` must be uniquely named")
  lib <- x_named_x_library()
  fit <- suppressWarnings(calibrate(lib$library, lib$field, n_iter = 400, burn_in = 50, seed = 1,
                                    discrepancy = gp_discrepancy()),
                          classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
  for (p in list(plot(fit, "ppc", ndraws = 50, seed = 1),
                 plot(fit, "discrepancy", ndraws = 50, seed = 1))) {
    expect_identical(levels(p$data$setting), c("x = 2", "x = 4", "x = 6"))
    expect_identical(p$labels$x, "t")
    expect_no_error(ggplot2::ggplotGrob(p))
  }
  post <- discrepancy_posterior(fit, ndraws = 50, seed = 1)
  expect_identical(names(post)[1:3], c("setting", "x", "t"))
})

test_that("one output per setting: ppc and discrepancy plots place settings by their values", {
  # the x axis was the setting's row ("x setting (row of the library's x)")
  k <- seq(0.5, 1.5, by = 0.05)
  x2 <- data.frame(load = c(2, 4, 6, 2, 4, 6), speed = rep(c(10, 20), each = 3))
  lib <- sim_library(data.frame(k = k), outer(k, x2$load) + rep(0.1 * x2$speed, each = length(k)),
                     x = x2)
  fit <- suppressWarnings(calibrate(lib, field_data(1.02 * x2$load + 0.1 * x2$speed +
                                                      c(0, 0, 0.8, 0, 0, 0)),
                                    n_iter = 200, burn_in = 50, seed = 1,
                                    discrepancy = gp_discrepancy()))
  labels <- paste0("load = ", x2$load, ", speed = ", x2$speed)
  for (p in list(plot(fit, "ppc", ndraws = 50, seed = 1),
                 plot(fit, "discrepancy", ndraws = 50, seed = 1))) {
    expect_identical(as.character(p$data$position), labels)
    expect_identical(p$labels$x, "x setting")
    built <- ggplot2::ggplot_build(p)
    expect_identical(as.character(built$layout$panel_params[[1]]$x$get_labels()),
                     paste0("load = ", x2$load, "\nspeed = ", x2$speed))
  }
  one_col <- sim_library(data.frame(k = k), outer(k, c(2, 4, 6)), x = data.frame(load = c(2, 4, 6)))
  fit1 <- suppressWarnings(calibrate(one_col, field_data(c(2.1, 4, 6.3)), n_iter = 200,
                                     burn_in = 50, seed = 1))
  pp <- plot(fit1, "ppc", ndraws = 50, seed = 1)
  expect_identical(pp$data$position, c(2, 4, 6))
  expect_identical(pp$labels$x, "load")
  # a library of one output: one point, no axis title
  single <- sim_library(data.frame(k = k), matrix(k, ncol = 1))
  fit0 <- suppressWarnings(calibrate(single, field_data(1.02), n_iter = 200, burn_in = 50,
                                     seed = 1))
  p0 <- plot(fit0, "ppc", ndraws = 50, seed = 1)
  expect_identical(as.character(p0$data$position), "single setting")
  expect_no_error(ggplot2::ggplotGrob(p0))
})

test_that("the ppc plot shows predictions at new settings beside the library's", {
  lib <- sim_library(data.frame(k = seq(1, 3, by = 0.01)), outer(seq(1, 3, by = 0.01), 1:4),
                     x = data.frame(pos = 1:4))
  fit <- suppressWarnings(calibrate(lib, field_data(c(2.1, 3.9, 6.2, 7.8)), n_iter = 600,
                                    burn_in = 100, seed = 1))
  linear <- function(theta, x) outer(theta$k, x$pos)
  # beyond pos = 4 a fit without a discrepancy says its band assumes the simulator
  expect_warning(pp <- plot(fit, "ppc", newdata = data.frame(pos = c(2, 5.5, 6)),
                            simulator = linear, ndraws = 200, seed = 1),
                 class = "griddy_warning_extrapolation")
  # one continuous x axis: the library's settings, then the new ones
  expect_identical(pp$data$position, c(1:4, 5.5, 6))
  expect_identical(pp$data$new, rep(c(FALSE, TRUE), c(4, 2)))
  expect_equal(pp$data[5:6, c("mean", "lower", "upper")],
               suppressWarnings(predict(fit, newdata = pp$data[1:6, "pos", drop = FALSE],
                                        ndraws = 200, seed = 1, simulator = linear),
                                classes = "griddy_warning_extrapolation")[5:6, c("mean", "lower",
                                                                                 "upper")],
               ignore_attr = TRUE)
  built <- ggplot2::ggplot_build(pp)
  expect_equal(built$data[[4]]$xintercept, c(1, 4))
  expect_equal(nrow(built$data[[5]]), 2)
  expect_match(pp$labels$subtitle, "through the\\s+simulator")
  expect_error(plot(fit, "ppc", newdata = data.frame(pos = 6)),
               class = "griddy_error_prediction")
  # settings all in the library: today's ppc of those settings
  expect_identical(plot(fit, "ppc", newdata = data.frame(pos = 2:3), ndraws = 50,
                        seed = 1)$labels$title, "Posterior predictive check")
})

test_that("the ppc plot of an emulated library shows its new settings' panels in x order", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 500)
  fit <- suppressWarnings(calibrate(lib, emulated_toy_field(), n_iter = 400, burn_in = 100,
                                    seed = 1))
  pp <- suppressWarnings(plot(fit, "ppc", newdata = data.frame(x = c(0.95, 0.35)), ndraws = 100,
                              seed = 1), classes = "griddy_warning_extrapolation")
  expect_identical(levels(pp$data$setting),
                   c("x = 0.20", "x = 0.35 (new)", "x = 0.50", "x = 0.80", "x = 0.95 (new)"))
  expect_match(pp$labels$subtitle, "emulator")
  expect_s3_class(ggplot2::ggplot_build(pp), "ggplot_built")
})
