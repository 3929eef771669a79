test_that("a design complete at the wanted settings is grouped by theta, in the library's layout", {
  theta <- cbind(k = c(1, 2, 1, 2, 3), c = c(5, 5, 5, 5, 5))
  x <- cbind(h = c(1, 1, 2, 2, 9))
  y <- cbind(theta[, "k"] * 10 + x[, "h"], theta[, "k"] * 100 + x[, "h"])
  got <- complete_design(list(theta = theta, x = x, y = y), cbind(h = c(2, 1)))
  # the run at h = 9 is not a wanted setting and is left out
  expect_equal(unname(got$theta[, "k"]), c(1, 2))
  expect_equal(got$y[1, ], c(12, 102, 11, 101))
  expect_equal(got$y[2, ], c(22, 202, 21, 201))
  expect_null(complete_design(list(theta = theta, x = x, y = y), cbind(h = c(1, 9))))
})

test_that("the theta form predicts the piston stand-in's 54 outputs from a complete design", {
  skip_if_not_installed("RobustGaSP")
  set.seed(1)
  rng <- piston_htc_ranges()
  lhs <- function(n) {
    u <- vapply(1:3, function(j) (sample.int(n) - stats::runif(n)) / n, numeric(n))
    th <- sweep(sweep(u, 2, rng$max - rng$min, "*"), 2, rng$min, "+")
    colnames(th) <- rng$parameter
    th
  }
  th <- lhs(60)
  y <- unname(piston_model(th, condition = c("full", "part")))
  lib <- emulated_library(th, y, n_runs = 100, seed = 1)
  expect_identical(lib$emulator$mode, "theta")
  truth <- unname(piston_model(as.matrix(lib$theta), condition = c("full", "part")))
  rel <- sqrt(colMeans((lib$y - truth)^2)) / apply(truth, 2, stats::sd)
  expect_lt(sqrt(mean(rel^2)), 0.15)
  # its error model is the leave-one-out residuals' over all 54 outputs
  expect_identical(nrow(lib$error$U), 54L)
})

test_that("the leave-one-out residuals are those of refitting without the run (fixed ranges)", {
  skip_if_not_installed("RobustGaSP")
  d <- emulated_toy_design(n = 25)
  lib <- emulated_library(d$theta, d$y, x = data.frame(x = d$x), t = d$t,
                          settings = d$settings, n_runs = 2, seed = 1)
  gp <- lib$emulator
  fit <- gp$fit
  R <- fit@L %*% t(fit@L)
  i <- 7
  Ri <- solve(R[-i, -i])
  H <- fit@X[-i, , drop = FALSE]
  beta <- solve(t(H) %*% Ri %*% H, t(H) %*% Ri %*% fit@output[-i, ])
  pred <- fit@X[i, , drop = FALSE] %*% beta +
    R[i, -i, drop = FALSE] %*% Ri %*% (fit@output[-i, ] - H %*% beta)
  expect_equal(unname(gp$loo[i, gp$vary]), unname(drop(fit@output[i, ] - pred)),
               tolerance = 1e-6)
})
