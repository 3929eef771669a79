test_that("leave-one-setting-out predictions are the exact posteriors of the reduced data", {
  toy <- toy_gap(0.2, rho_t = c(0, 0.3))
  # max_runs = 0: the libraries as they are, to compare with posterior_exact()
  gap <- diagnose_gap(toy$fit, list(quadratic = toy$quad), max_runs = 0)
  n_t <- length(toy$t)
  lp <- candidate_log_prior(toy$quad, "a")
  for (model in c("none", "quadratic")) {
    lib <- if (model == "none") toy$lib else toy$quad
    w <- if (model == "none") NULL else exp(lp)
    full <- posterior_exact(lib, toy$field, rho_t = c(0, 0.3), run_weights = w)$log_evidence
    for (k in 1:3) {
      cols <- (k - 1) * n_t + seq_len(n_t)
      red_lib <- sim_library(lib$theta, lib$y[, -cols], x = toy$x[-k, , drop = FALSE], t = toy$t)
      red_field <- field_data(toy$field$y[-k, ], x = toy$x[-k, , drop = FALSE], t = toy$t)
      ex <- posterior_exact(red_lib, red_field, rho_t = c(0, 0.3), run_weights = w)
      fold <- gap$folds[gap$folds$model == model & gap$folds$x == k, ]
      expect_equal(fold$lpd, full - ex$log_evidence, tolerance = 1e-8)
      pred <- drop(ex$run %*% lib$y[, cols])
      expect_equal(fold$rmse, sqrt(mean((toy$field$y[k, ] - pred)^2)), tolerance = 1e-8)
    }
  }
})

test_that("shrinkage pools the folds", {
  toy <- toy_gap(0.2)
  gap <- diagnose_gap(toy$fit, list(quadratic = toy$quad))
  f <- gap$folds
  sh <- gap$shrinkage
  expect_equal(sh$before, sqrt(sum(f$sse[f$model == "none"]) / 90))
  expect_equal(sh$shrink, 1 - sh$after / sh$before)
  expect_equal(sh$lpd_after, sum(f$lpd[f$model == "quadratic"]))
  expect_true(all(sh$cover90_after >= 0 & sh$cover90_after <= 1))
  # with the right effect the 90% intervals cover about 90% of held-out points
  expect_gt(sh$cover90_after, 0.75)
})

test_that("leaving out a setting is exact with correlation across settings too", {
  toy <- toy_gap(0.2)
  fit <- suppressWarnings(calibrate(toy$lib, toy$field, rho_x = 0.5, rho_t = 0.3,
                                    n_iter = 200, burn_in = 50, seed = 1))
  gap <- diagnose_gap(fit, list(quadratic = toy$quad))
  full <- posterior_exact(toy$lib, toy$field, rho_x = 0.5, rho_t = 0.3)$log_evidence
  # the middle setting: leaving it out keeps the range that scales x
  cols <- 30 + 1:30
  red_lib <- sim_library(toy$lib$theta, toy$lib$y[, -cols], x = toy$x[-2, , drop = FALSE],
                         t = toy$t)
  red_field <- field_data(toy$field$y[-2, ], x = toy$x[-2, , drop = FALSE], t = toy$t)
  ex <- posterior_exact(red_lib, red_field, rho_x = 0.5, rho_t = 0.3)
  fold <- gap$folds[gap$folds$model == "none" & gap$folds$x == 2, ]
  expect_equal(fold$lpd, full - ex$log_evidence, tolerance = 1e-8)
  expect_equal(fold$rmse, sqrt(mean((toy$field$y[2, ] - drop(ex$run %*% toy$lib$y[, cols]))^2)),
               tolerance = 1e-8)
})

test_that("with missing cells and sd, leaving out a setting's observed cells is exact", {
  miss <- c(3, 4, 40:47, 70)
  rs <- rep(c(1, 2, 0.5), each = 30)
  toy <- toy_gap(0.2, rho_t = c(0, 0.3), missing = miss, rel_sd = rs)
  gap <- diagnose_gap(toy$fit, list(quadratic = toy$quad), max_runs = 0)
  full <- posterior_exact(toy$lib, toy$field, rho_t = c(0, 0.3))$log_evidence
  for (k in 1:3) {
    cols <- (k - 1) * 30 + 1:30
    red_lib <- sim_library(toy$lib$theta, toy$lib$y[, -cols], x = toy$x[-k, , drop = FALSE],
                           t = toy$t)
    red_field <- field_data(toy$field$y[-k, ], x = toy$x[-k, , drop = FALSE], t = toy$t,
                            sd = toy$field$sd[-k, ])
    ex <- posterior_exact(red_lib, red_field, rho_t = c(0, 0.3))
    fold <- gap$folds[gap$folds$model == "none" & gap$folds$x == k, ]
    seen <- setdiff(cols, miss)
    expect_identical(fold$n, length(seen))
    expect_equal(fold$lpd, full - ex$log_evidence, tolerance = 1e-8)
    y_b <- as.vector(t(toy$field$y))[seen]
    expect_equal(fold$rmse, sqrt(mean((y_b - drop(ex$run %*% toy$lib$y[, seen]))^2)),
                 tolerance = 1e-8)
  }
})

test_that("a setting with no observed cell has no fold", {
  toy <- toy_gap(0.2, missing = 31:60)
  gap <- diagnose_gap(toy$fit, list(quadratic = toy$quad), max_runs = 0)
  expect_setequal(gap$folds$x, c(1, 3))
  expect_equal(sum(gap$folds$n[gap$folds$model == "none"]), 60)
  ctx <- gap_context(toy$fit)
  tm <- gap_terms(ctx, toy$lib$y, toy$fit$log_prior_run)
  expect_true(all(tm$D[, , 2] == 0))
  expect_equal(nrow(gap$where[gap$where$x == 2 & gap$where$n == 0, ]),
               sum(gap$where$x == 2))
})
