# delta | y at run i and grid point g by dense algebra over the measured
# cells, group by group: mean lambda K_.o Sigma^-1 r and covariance (per unit
# tau^-1) lambda K - lambda K_.o Sigma^-1 lambda K_o., Sigma = S R S + lambda K.
brute_delta <- function(fit, i, g, sd, groups) {
  setup <- fit$setup
  d <- setup$discrepancy[setup$gd[g], ]
  K <- d$ratio * discrepancy_kernels(fit$library, attr(setup$discrepancy, "kernels"))[[d$kernel]]
  point <- grid_point(setup, g)
  R <- kronecker(crossprod(point$Rx_chol),
                 corr_t(lib_t(fit$library), setup$rho_t[setup$gt[g]]))
  Sigma <- diag(sd) %*% R %*% diag(sd) + K
  r <- fit$y_field - lib_outputs(fit$library, i)[1, ]
  n <- length(r)
  mean <- numeric(n)
  cov <- matrix(0, n, n)
  for (k in unique(groups)) {
    cells <- which(groups == k)
    o <- intersect(which(!is.na(r)), cells)
    mean[cells] <- K[cells, o] %*% solve(Sigma[o, o], r[o])
    cov[cells, cells] <- K[cells, cells] - K[cells, o] %*% solve(Sigma[o, o], K[o, cells])
  }
  list(mean = mean, cov = cov)
}

test_that("delta | y at a run and grid point is the Gaussian conditional, per noise group", {
  case <- missing_groups_fit()
  fit <- case$fit
  sd <- case$sd
  groups <- case$groups
  for (g in which(fit$grid$delta_ratio > 0)) {
    at <- delta_law(fit$setup, g, fit_kernels(fit))
    want <- brute_delta(fit, 3, g, sd, groups)
    expect_equal(delta_means(at, run_residuals(fit, 3))[1, ], want$mean, tolerance = 1e-10)
    P <- matrix(0, 15, 15)
    for (grp in at$groups) P[grp$cells, grp$cells] <- delta_cov(grp)
    expect_equal(P, want$cov, tolerance = 1e-10)
  }
  # the draws at one (run, grid point, tau) have that mean and covariance / tau
  g <- max(which(fit$grid$delta_ratio > 0))
  fit$draws <- fit$draws[rep(1, 20000), ]
  fit$draws$run <- 3L
  fit$draws$grid_point <- g
  fit$draws$tau_1 <- 4
  fit$draws$tau_2 <- 0.25
  set.seed(2)
  d <- discrepancy_draws(fit, seq_len(20000))
  want <- brute_delta(fit, 3, g, sd, groups)
  scale <- ifelse(groups == 1, 1 / 2, 2)  # 1 / sqrt(tau) of each output's group
  expect_lt(max(abs(colMeans(d) - want$mean) / (sqrt(diag(want$cov)) * scale + 1e-12)), 0.05)
  expect_lt(max(abs(stats::cov(d) - want$cov * outer(scale, scale))), 0.05 * max(want$cov * 4))
  m <- discrepancy_moments(fit)
  expect_equal(m$mean, want$mean, tolerance = 1e-10)
  expect_equal(m$sd, sqrt(pmax(diag(want$cov), 0)) * scale, tolerance = 1e-8)
})

test_that("with replicates delta | y is the conditional given every measurement", {
  toy <- toy_replicates(sd = matrix(rep(c(1, 0.5, 2), 10), 6, 5))
  fit <- suppressWarnings(calibrate(
    toy$library, toy$field, n_iter = 100, burn_in = 10, seed = 1,
    discrepancy = gp_discrepancy(ratio = c(0, 3), length_x = 0.5, length_t = 0.5)))
  g <- which(fit$grid$delta_ratio > 0)
  at <- delta_law(fit$setup, g, fit_kernels(fit))
  # every measurement: y_r = g + delta(cell) + e_r, e_r ~ N(0, sd_r^2 / tau) independent
  K <- 3 * discrepancy_kernels(fit$library, attr(fit$setup$discrepancy, "kernels"))[[1]]
  cell <- as.vector(outer((toy$rows - 1L) * 5L, 1:5, "+"))
  y <- as.vector(toy$y_rep)
  keep <- !is.na(y)
  cell <- cell[keep]
  Z <- diag(15)[cell, ]
  Sigma <- diag(as.vector(toy$sd)[keep]^2) + Z %*% K %*% t(Z)
  r <- y[keep] - toy$Y[2, cell]
  expect_equal(delta_means(at, run_residuals(fit, 2))[1, ], drop(K %*% t(Z) %*% solve(Sigma, r)),
               tolerance = 1e-10)
  expect_equal(delta_cov(at$groups[[1]]),
               K - K %*% t(Z) %*% solve(Sigma, Z %*% K), tolerance = 1e-10)
})

test_that("the posterior of delta recovers an added bump, and says where it is", {
  sys <- bump_sys()
  fit <- bump_fit(sys)
  post <- discrepancy_posterior(fit, ndraws = 400, seed = 1)
  expect_identical(names(post), c("x", "amp", "t", "observed", "residual", "mean", "sd",
                                  "lower", "upper"))
  expect_identical(nrow(post), 63L)
  gap <- seen_gap(sys, fit)
  # a bump of 0.4, the cells' noise sd 0.05 or 0.08 / sqrt(3): closer to the
  # gap than the data are, though the smooth trims the bump's peak a little
  expect_lt(max(abs(post$mean - gap)), 0.12)
  expect_lt(sqrt(mean((post$mean - gap)^2)), 0.04)
  expect_gt(mean(post$lower <= gap & gap <= post$upper), 0.9)
  expect_true(all(post$lower <= post$mean & post$mean <= post$upper))
  # the bump's cells stand out; far from it the band holds 0
  bump <- sys$gap > 0.2
  expect_gte(sum(bump), 3)
  expect_true(all(post$lower[bump] > 0))
  expect_gt(mean(post$lower[post$amp == 1] <= 0 & post$upper[post$amp == 1] >= 0), 0.9)
  regions <- discrepancy_regions(cbind(library_cells(fit$library),
                                       as.data.frame(discrepancy_moments(fit))), fit$library)
  expect_identical(regions$setting[1], "amp = 3")
  expect_true(regions$t_from[1] <= 0.45 && regions$t_to[1] >= 0.55)
  expect_true(regions$t_from[1] >= 0.2 && regions$t_to[1] <= 0.8)
  # calibrate()'s warning names the place
  w <- NULL
  withCallingHandlers(
    calibrate(sys$library, sys$field, n_iter = 1000, burn_in = 200, seed = 1,
              discrepancy = gp_discrepancy()),
    griddy_warning_gap = function(c) {
      w <<- c
      invokeRestart("muffleWarning")
    },
    griddy_warning_resolution = function(c) invokeRestart("muffleWarning"))
  expect_s3_class(w, "griddy_warning_gap")
  expect_match(conditionMessage(w),
               "band excludes 0 at [0-9]+ of 63 outputs, clearest at amp = 3, t in")
})

test_that("without a gap delta's band holds 0; lambda = 0 draws give 0", {
  sys <- bump_sys(bump = 0)
  fit <- bump_fit(sys)
  post <- discrepancy_posterior(fit, ndraws = 400, seed = 1)
  expect_gt(mean(post$lower <= 0 & post$upper >= 0), 0.95)
  expect_lt(max(abs(post$mean)), 0.05)
  expect_match(discrepancy_where_text(fit), "band (holds 0 everywhere|excludes 0 at [1-3] of)")
  none <- which(fit$grid$delta_ratio == 0)[1]
  fit$draws$grid_point <- none
  expect_identical(max(abs(discrepancy_draws(fit, 1:50))), 0)
  expect_identical(discrepancy_moments(fit), list(mean = numeric(63), sd = numeric(63)))
})

test_that("noise groups and replicated fields give delta's posterior", {
  sys <- bump_sys(reps = 3, sd = 0.08, seed = 2)
  fit <- bump_fit(sys, noise_groups = "x")
  expect_identical(tau_columns(fit), c("tau_x1", "tau_x2", "tau_x3"))
  post <- discrepancy_posterior(fit, ndraws = 300, seed = 1)
  gap <- seen_gap(sys, fit)
  # a bump of 0.4, the cells' noise sd 0.05 or 0.08 / sqrt(3): closer to the
  # gap than the data are, though the smooth trims the bump's peak a little
  expect_lt(max(abs(post$mean - gap)), 0.12)
  expect_lt(sqrt(mean((post$mean - gap)^2)), 0.04)
  expect_gt(mean(post$lower <= gap & gap <= post$upper), 0.9)
  expect_true(all(post$lower[sys$gap > 0.2] > 0))
  # the residual is the replicates' mean minus the simulator's mean outputs
  expect_equal(post$residual, fit$y_field - posterior_mean_outputs(fit))
})

test_that("the draws are reproducible with set.seed() and with seed", {
  fit <- bump_fit(bump_sys())
  set.seed(7)
  a <- discrepancy_posterior(fit, ndraws = 50)
  set.seed(7)
  b <- discrepancy_posterior(fit, ndraws = 50)
  expect_identical(a, b)
  expect_identical(discrepancy_posterior(fit, ndraws = 50, seed = 3),
                   discrepancy_posterior(fit, ndraws = 50, seed = 3))
  expect_false(identical(attr(a, "draws"), attr(discrepancy_posterior(fit, ndraws = 50, seed = 3),
                                                "draws")))
  expect_identical(dim(attr(a, "draws")), c(50L, 63L))
  expect_identical(attr(a, "draw_rows"), evenly_spaced_draws(fit, 50))
})

test_that("discrepancy_posterior() refuses a fit without a discrepancy", {
  sys <- bump_sys()
  fit <- suppressWarnings(calibrate(sys$library, sys$field, n_iter = 100, burn_in = 10, seed = 1))
  expect_error(discrepancy_posterior(fit), class = "griddy_error_input",
               regexp = "has no discrepancy")
  expect_error(discrepancy_posterior(list()), class = "griddy_error_input")
  fit_d <- bump_fit(sys)
  expect_error(discrepancy_posterior(fit_d, level = 1), "`level`")
  expect_error(discrepancy_posterior(fit_d, ndraws = 0), "`ndraws`")
})

test_that("a refined fit's runs give delta's posterior", {
  theta <- data.frame(k = seq(1, 4, by = 0.5))
  lib <- sim_library(theta, refine_sim(theta))
  # refine_sim()'s times are seq(0, 1, length.out = 40); the library's t is 1:40
  bump <- 0.1 * exp(-((seq(0, 1, length.out = 40) - 0.6) / 0.1)^2)
  set.seed(1)
  field <- field_data(refine_sim(data.frame(k = 2.23)) + bump + stats::rnorm(40, sd = 0.02),
                      t = lib_t(lib))
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 600, burn_in = 200, seed = 1,
                                    discrepancy = gp_discrepancy(orthogonal = FALSE)))
  refined <- suppressWarnings(refine(fit, refine_sim, max_runs = 200, seed = 1))
  post <- discrepancy_posterior(refined, ndraws = 200, seed = 1)
  expect_gt(mean(post$lower <= bump & bump <= post$upper), 0.9)
  expect_true(sum(bump > 0.07) >= 3 && all(post$lower[bump > 0.07] > 0))
  expect_match(discrepancy_where_text(refined),
               "band excludes 0 at [0-9]+ of 40 outputs, clearest at t in \\[2[0-9], [23][0-9]\\]")
})

test_that("an orthogonal discrepancy's posterior leaves theta's directions alone", {
  sys <- bump_sys()
  fit <- suppressWarnings(calibrate(sys$library, sys$field, n_iter = 400, burn_in = 100,
                                    seed = 1, discrepancy = gp_discrepancy()))
  G <- attr(attr(fit$setup$discrepancy, "kernels"), "sensitivity")
  post <- discrepancy_posterior(fit, ndraws = 100, seed = 1)
  expect_lt(abs(sum(post$mean * G[, 1])), 1e-6 * sqrt(sum(post$mean^2) * sum(G[, 1]^2)))
  # the bump, which k cannot imitate, is still found
  expect_true(all(post$lower[sys$gap > 0.3] > 0))
})

test_that("delta's draws use the symmetric square root, which rounding cannot turn", {
  # P with a repeated eigenvalue and a null space, made twice: the same
  # matrix to rounding, through two bases of the repeated eigenspace
  set.seed(4)
  V <- qr.Q(qr(matrix(rnorm(36), 6)))
  turn <- diag(6)
  turn[1:2, 1:2] <- matrix(c(cos(1), sin(1), -sin(1), cos(1)), 2)
  P1 <- V %*% diag(c(2, 2, 1, 0.5, 0, 0)) %*% t(V)
  W <- V %*% turn
  P2 <- W %*% diag(c(2, 2, 1, 0.5, 0, 0)) %*% t(W)
  P2 <- (P2 + t(P2)) / 2
  expect_lt(max(abs(P1 - P2)), 1e-14)
  S1 <- sqrt_psd(P1)
  expect_equal(S1, t(S1))
  expect_equal(S1 %*% S1, P1, tolerance = 1e-10)
  # a draw Z S moves with P alone (an eigenvector factor, as before, is
  # free to turn within the repeated eigenvalue and to change sign)
  expect_lt(max(abs(S1 - sqrt_psd(P2))), 1e-7)
  expect_equal(sqrt_psd(matrix(0, 2, 2)), matrix(0, 2, 2))
})
