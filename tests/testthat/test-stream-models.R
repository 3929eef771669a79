# Model probabilities as data arrive, against the batch evidences.

rival_library <- function(lib, offset = 0.5) {
  sim_library(lib$theta, lib$y + offset, x = lib$x, t = lib$t)
}

test_that("without forgetting the probabilities are the batch evidences' ratios", {
  ex <- griddy_example()
  rival <- rival_library(ex$library)
  m <- stream_models(spring = griddy_stream(ex$library, rho_t = c(0, 0.5)),
                     damped = griddy_stream(rival, rho_t = c(0, 0.5)), prior = c(1, 3))
  update(m, y = ex$field)
  h <- as.data.frame(m)
  expect_equal(nrow(h), length(ex$field$y))
  ev <- c(posterior_exact(ex$library, ex$field, rho_t = c(0, 0.5))$log_evidence,
          posterior_exact(rival, ex$field, rho_t = c(0, 0.5))$log_evidence)
  expect_equal(unname(logLik(m)), ev, tolerance = 1e-10)
  p <- c(1, 3) * exp(ev - max(ev))
  expect_equal(unname(unlist(h[nrow(h), c("prob_spring", "prob_damped")])), p / sum(p),
               tolerance = 1e-8)
  # the predictive densities add up to the evidences
  expect_equal(sum(h$log_pred_spring), ev[1], tolerance = 1e-10)
  expect_equal(h$mass, rep(ex$field$x$mass, each = ncol(ex$field$y)))
  expect_output(print(m), "griddy_stream_models")
})

test_that("forgetting discounts old evidence and follows a change of model", {
  ex <- griddy_example()
  rival <- rival_library(ex$library, 5)
  x1 <- ex$field$x[1, , drop = FALSE]
  exact <- stream_models(a = griddy_stream(ex$library), b = griddy_stream(rival))
  dma <- stream_models(a = griddy_stream(ex$library), b = griddy_stream(rival),
                       forgetting = 0.7)
  # first the data of model a, then outputs of model b's best run
  y_a <- ex$field$y[1, ]
  y_b <- ex$library$y[which.max(posterior_exact(ex$library, ex$field)$run), 1:30] + 5
  for (m in list(exact, dma)) {
    update(m, y = y_a[1:15], x = x1, t = ex$library$t[1:15])
    update(m, y = y_b[16:30], x = x1, t = ex$library$t[16:30])
  }
  h_exact <- as.data.frame(exact)
  h_dma <- as.data.frame(dma)
  expect_gt(h_exact$prob_a[15], 0.9)
  expect_gt(h_dma$prob_a[15], 0.9)
  # the discounted probabilities: alpha-weighted sums of the predictive densities
  w <- 0.7^(30 - seq_len(30))
  lp <- c(sum(w * h_dma$log_pred_a), sum(w * h_dma$log_pred_b))
  expect_equal(h_dma$prob_b[30], exp(lp[2] - log_sum_exp(lp)), tolerance = 1e-8)
  # after the change, forgetting turns to b no later than the exact probabilities
  turn <- function(h) which(h$prob_b[16:30] > 0.5)[1]
  expect_true(!is.na(turn(h_dma)))
  expect_true(is.na(turn(h_exact)))
  expect_gt(h_dma$prob_b[30], 0.9)
})

test_that("models need named streams with the same data", {
  ex <- griddy_example()
  expect_error(stream_models(griddy_stream(ex$library), griddy_stream(ex$library)),
               class = "griddy_error_input")
  s <- update(griddy_stream(ex$library), y = ex$field)
  expect_error(stream_models(a = s, b = griddy_stream(ex$library)),
               class = "griddy_error_input")
  expect_error(stream_models(a = griddy_stream(ex$library), b = griddy_stream(ex$library),
                             forgetting = 0), class = "griddy_error_input")
})

test_that("the same stream given for two models is refused (issue 32)", {
  ex <- griddy_example()
  s <- griddy_stream(ex$library)
  # before: accepted, and every update then reached the stream twice
  expect_error(stream_models(a = s, b = s), class = "griddy_error_duplicate_stream")
  expect_error(stream_models(a = s, b = griddy_stream(ex$library), c = s),
               "`a` and `c` are the same stream")
  # a copy of a stream is the same reference object
  s2 <- s
  expect_error(stream_models(a = s, b = s2), class = "griddy_error_duplicate_stream")
})

test_that("an update refused by one model reaches none (issue 32)", {
  ex <- griddy_example()
  x1 <- ex$field$x[1, , drop = FALSE]
  # `b` refuses a replicate under AR(1); `a` (independent noise) takes it
  m <- stream_models(a = griddy_stream(ex$library), b = griddy_stream(ex$library, rho_t = c(0, 0.5)))
  update(m, y = ex$field$y[1, 1:3], x = x1, t = ex$library$t[1:3])
  before <- list(logLik(m), as.data.frame(m), vapply(m$streams, nobs, integer(1)),
                 lapply(m$streams, function(s) posterior_exact(s, joint = FALSE)))
  expect_error(update(m, y = c(ex$field$y[1, 4], 0.3), x = x1, t = ex$library$t[c(4, 2)]),
               class = "griddy_error_unsupported")
  # before: `a` held 5 measurements and `b` 4, and the print compared their evidences
  after <- list(logLik(m), as.data.frame(m), vapply(m$streams, nobs, integer(1)),
                lapply(m$streams, function(s) posterior_exact(s, joint = FALSE)))
  expect_identical(after, before)
  # the models go on from there as if the refused update had not been made
  update(m, y = ex$field$y[1, 4:30], x = x1, t = ex$library$t[4:30])
  field <- field_data(ex$field$y[1, , drop = FALSE], x = x1, t = ex$library$t)
  ev <- c(posterior_exact(ex$library, field)$log_evidence,
          posterior_exact(ex$library, field, rho_t = c(0, 0.5))$log_evidence)
  expect_equal(unname(logLik(m)), ev, tolerance = 1e-10)
  expect_identical(nrow(as.data.frame(m)), 30L)
})

test_that("measurements one model's library lacks are refused before any model takes them", {
  ex <- griddy_example()
  lib <- ex$library
  keep <- seq_len(ncol(lib$y)) %% 30 != 0  # the last t at every setting
  short <- sim_library(lib$theta, lib$y[, keep], x = lib$x, t = lib$t[-30])
  m <- stream_models(a = griddy_stream(lib), b = griddy_stream(short))
  x1 <- ex$field$x[1, , drop = FALSE]
  expect_error(update(m, y = ex$field$y[1, 29:30], x = x1, t = lib$t[29:30]),
               class = "griddy_error")
  expect_identical(vapply(m$streams, nobs, integer(1)), c(a = 0L, b = 0L))
  expect_identical(nrow(as.data.frame(m)), 0L)
})

test_that("a stream updated outside the model choice stops the next update", {
  ex <- griddy_example()
  x1 <- ex$field$x[1, , drop = FALSE]
  a <- griddy_stream(ex$library)
  m <- stream_models(a = a, b = griddy_stream(ex$library))
  update(m, y = ex$field$y[1, 1:2], x = x1, t = ex$library$t[1:2])
  update(a, y = ex$field$y[1, 3], x = x1, t = ex$library$t[3])
  expect_error(update(m, y = ex$field$y[1, 4], x = x1, t = ex$library$t[4]),
               "`a` hold 3 measurement\\(s\\) where the models have taken 2",
               class = "griddy_error_stream_changed")
  expect_identical(nobs(m$streams$b), 2L)
})
