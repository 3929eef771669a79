# predict() of a stream (stream-predict.R).

stream_machine <- function(step = 0.0005, sd = 0.05) {
  x <- data.frame(x = seq(0.2, 4, length.out = 11))
  theta <- data.frame(theta = seq(0.3, 1, by = step))
  set.seed(1)
  list(library = sim_library(theta, outer(theta$theta, x$x), x = x), x = x,
       field = field_data(matrix(0.65 * x$x + stats::rnorm(11, sd = sd)), x = x),
       simulator = function(theta, x) outer(theta$theta, x$x))
}

test_that("at library settings a stream's mean and band are the exact posterior's", {
  m <- stream_machine()
  s <- update(griddy_stream(m$library), y = m$field)
  p <- predict(s, ndraws = 2000, seed = 1)
  post <- posterior_exact(m$library, m$field)$run
  Y <- lib_outputs(m$library)
  expect_equal(p$mean, as.vector(crossprod(post, Y)))
  expect_equal(p$upper, apply(Y, 2, weighted_quantile, w = post, probs = 0.975))
  expect_equal(p$observed, m$field$y[, 1])
  # as calibrate()'s, whose chain samples the same posterior
  fit <- suppressWarnings(calibrate(m$library, m$field, n_iter = 4000, burn_in = 200, seed = 1))
  q <- predict(fit, ndraws = 2000, seed = 1)
  expect_equal(p$mean, q$mean, tolerance = 1e-3)
  expect_equal(p$pred_upper - p$pred_lower, q$pred_upper - q$pred_lower, tolerance = 0.08)
  # one measurement so far: `observed` holds it, NA elsewhere
  one <- update(griddy_stream(m$library), y = 0.5, x = m$x[2, , drop = FALSE], t = 1)
  expect_identical(is.na(predict(one, ndraws = 50, seed = 1)$observed), seq_len(11) != 2)
})

test_that("a stream predicts at a new setting as the closed-form Student t", {
  m <- stream_machine()
  s <- update(griddy_stream(m$library), y = m$field)
  y <- m$field$y[, 1]
  x <- m$x$x
  sxx <- sum(x^2)
  theta_hat <- sum(x * y) / sxx
  sres <- sqrt(sum((y - theta_hat * x)^2) / (length(y) - 1))
  q <- stats::qt(0.975, length(y) - 1)
  p <- predict(s, newdata = data.frame(x = 6), ndraws = 6000, seed = 1,
               simulator = m$simulator)
  sd_mean <- 6 * sres / sqrt(sxx)
  expect_equal(p$mean, 6 * theta_hat, tolerance = 0.05 * sd_mean / (6 * theta_hat))
  expect_equal(c(p$lower, p$upper), 6 * theta_hat + c(-1, 1) * q * sd_mean, tolerance = 2e-3)
  expect_equal(c(p$pred_lower, p$pred_upper),
               6 * theta_hat + c(-1, 1) * q * sres * sqrt(1 + 36 / sxx), tolerance = 5e-3)
  # the library's rows keep their answer beside new ones
  at <- data.frame(x = c(x[3], 6))
  both <- predict(s, newdata = at, ndraws = 300, seed = 2, simulator = m$simulator)
  expect_equal(both[1, ], predict(s, newdata = at[1, , drop = FALSE], ndraws = 300, seed = 2),
               ignore_attr = TRUE)
  expect_true(is.na(both$setting[2]))
})

test_that("a stream's noise groups (and AR(1) grid) extend to new settings as a fit's", {
  sys <- bump_sys(bump = 0, n_t = 6)
  t <- lib_t(sys$library)
  simulator <- function(theta, x) {
    t(vapply(theta$k, function(k) unlist(lapply(x$amp, function(a) k * a * (1 + t))),
             numeric(nrow(x) * length(t))))
  }
  groups <- rep(c("a", "b"), each = 3)
  # group b (the last three t) five times noisier
  y <- matrix(sys$field$y, 3)
  set.seed(5)
  y[, 4:6] <- y[, 4:6] + stats::rnorm(9, sd = 0.25)
  field <- field_data(y, x = data.frame(amp = 1:3), t = t)
  s <- update(griddy_stream(sys$library, rho_t = c(0, 0.5), noise_groups = groups),
              y = field)
  fit <- suppressWarnings(calibrate(sys$library, field, rho_t = c(0, 0.5), n_iter = 3000,
                                    burn_in = 200, seed = 1, noise_groups = groups))
  ps <- predict(s, newdata = data.frame(amp = 4), ndraws = 4000, seed = 1,
                simulator = simulator)
  pf <- suppressWarnings(predict(fit, newdata = data.frame(amp = 4), ndraws = 3000, seed = 1,
                                 simulator = simulator),
                         classes = "griddy_warning_extrapolation")
  expect_equal(ps$mean, pf$mean, tolerance = 1e-3)
  width <- ps$pred_upper - ps$pred_lower
  expect_equal(width, pf$pred_upper - pf$pred_lower, tolerance = 0.1)
  expect_gt(min(width[4:6]), 2 * max(width[1:3]))
  by_x <- update(griddy_stream(sys$library, noise_groups = "x"), y = field)
  expect_error(predict(by_x, newdata = data.frame(amp = 4), simulator = simulator),
               class = "griddy_error_unsupported")
})

test_that("a stream's new settings without a simulator are a classed error", {
  m <- stream_machine(step = 0.01)
  s <- update(griddy_stream(m$library), y = m$field)
  expect_error(predict(s, newdata = data.frame(x = 6)), "no emulator over x",
               class = "griddy_error_prediction")
  expect_error(predict(s, newdata = data.frame(x = 6), simulator = m$simulator, run_mass = 2),
               class = "griddy_error_input")
  expect_error(predict(griddy_stream(m$library)), class = "griddy_error_input")
})

# Two models of the simple machine: theta x, and a rival theta x^2 / 2.
machine_models <- function(n_meas = 11) {
  m <- stream_machine()
  rival_sim <- function(theta, x) outer(theta$theta, x$x^2 / 2)
  rival <- sim_library(lib_theta(m$library), rival_sim(lib_theta(m$library), m$x), x = m$x)
  choice <- stream_models(line = griddy_stream(m$library), square = griddy_stream(rival))
  y <- m$field$y[seq_len(n_meas), 1]
  choice <- update(choice, y = y, x = m$x[seq_len(n_meas), , drop = FALSE],
                   t = rep(1, n_meas))
  list(m = m, choice = choice, sims = list(line = m$simulator, square = rival_sim))
}

test_that("a model choice predicts its models' predictions mixed by their probabilities", {
  mm <- machine_models(n_meas = 2)
  prob <- exp(mm$choice$state$log_prob)
  expect_true(all(prob > 0.05))  # a choice not yet made
  p <- predict(mm$choice, ndraws = 4000, seed = 1)
  each <- lapply(mm$choice$streams, predict, ndraws = 4000, seed = 1)
  expect_equal(p$mean, prob[1] * each$line$mean + prob[2] * each$square$mean)
  # the bounds are the mixture's quantiles over both models' runs
  post <- lapply(mm$choice$streams, function(s) stream_margins(s)$run)
  Y <- rbind(lib_outputs(mm$choice$streams$line$state$library),
             lib_outputs(mm$choice$streams$square$state$library))
  w <- c(prob[1] * post[[1]], prob[2] * post[[2]])
  expect_equal(p$upper, apply(Y, 2, weighted_quantile, w = w, probs = 0.975))
  # where the models disagree most (x = 4: 4 theta against 8 theta) the band spans both
  far <- nrow(p)
  expect_lt(p$lower[far], min(each$line$upper[far], each$square$upper[far]))
  expect_gt(p$upper[far], max(each$line$lower[far], each$square$lower[far]))
  expect_equal(p$observed, each$line$observed)
})

test_that("a settled model choice predicts as its model, at new settings too", {
  mm <- machine_models()
  prob <- exp(mm$choice$state$log_prob)
  expect_gt(prob[1], 1 - 1e-8)
  at <- data.frame(x = c(1.52, 6))
  p <- predict(mm$choice, newdata = at, ndraws = 2000, seed = 1, simulator = mm$sims)
  line <- predict(mm$choice$streams$line, newdata = at, ndraws = 2000, seed = 1,
                  simulator = mm$m$simulator)
  expect_equal(p$mean, line$mean, tolerance = 1e-8)
  expect_equal(p[c("lower", "upper")], line[c("lower", "upper")], tolerance = 1e-8)
  expect_equal(p$pred_upper - p$pred_lower, line$pred_upper - line$pred_lower,
               tolerance = 0.05)
  # new settings need a simulator for every model
  expect_error(predict(mm$choice, newdata = at, simulator = list(line = mm$m$simulator)),
               class = "griddy_error_input")
  expect_error(predict(mm$choice, newdata = at), class = "griddy_error_prediction")
})

test_that("models whose libraries hold other settings cannot be mixed", {
  m <- stream_machine()
  # settings shifted by one step: they share 10 of their 11
  shifted <- data.frame(x = m$x$x + 0.38)
  other <- sim_library(lib_theta(m$library), outer(lib_theta(m$library)$theta, shifted$x),
                       x = shifted)
  choice <- stream_models(a = griddy_stream(m$library), b = griddy_stream(other))
  choice <- update(choice, y = 0.6, x = data.frame(x = 0.96), t = 1)
  expect_error(predict(choice, ndraws = 50), class = "griddy_error_unsupported")
})
