# delta's conditional law (discrepancy-law.R) and its two readers:
# discrepancy_posterior()'s moments (fit draws, tau drawn) and diagnose_gap()'s
# discrepancy_where() (exact pairs, tau integrated out).

# A fit of toy_missing() with missing cells, a relative sd and two noise
# groups, and a discrepancy (a plain GaSP, so that every block's conditional
# covariance has full rank and its statistic has a closed form below).
law_fit <- function() missing_groups_fit(orthogonal = FALSE)

# The Gaussian conditional of delta at run i, grid point g by dense algebra,
# per noise group k (o its observed cells, c all its cells): the mean
# K_co Sigma_oo^-1 e and covariance K_cc - K_co Sigma_oo^-1 K_oc, with
# Sigma = S R S + K, R = R_x (x) R_t built from the grid's rho, K = lambda
# times the fit's kernel, e = y - g_i; also each group's quadratic form
# e_o' Sigma_oo^-1 e_o and size.
brute_conditional <- function(lf, i, g) {
  fit <- lf$fit
  gr <- fit$grid[g, ]
  d <- fit$setup$discrepancy[fit$setup$gd[g], ]
  K <- d$ratio * discrepancy_kernels(fit$library, attr(fit$setup$discrepancy, "kernels"))[[d$kernel]]
  R <- kronecker(corr_x(lf$toy$x, gr$rho_x_h), corr_t(lf$toy$t, gr$rho_t))
  Sigma <- diag(lf$sd) %*% R %*% diag(lf$sd) + K
  e <- lf$toy$y - lf$toy$Y[i, ]
  mean <- numeric(15)
  cov <- matrix(0, 15, 15)
  C <- numeric(0)
  n <- numeric(0)
  for (k in sort(unique(lf$groups))) {
    cells <- which(lf$groups == k)
    o <- intersect(which(!is.na(e)), cells)
    mean[cells] <- K[cells, o] %*% solve(Sigma[o, o], e[o])
    cov[cells, cells] <- K[cells, cells] - K[cells, o] %*% solve(Sigma[o, o], K[o, cells])
    C[k] <- sum(e[o] * solve(Sigma[o, o], e[o]))
    n[k] <- length(o)
  }
  list(mean = mean, cov = cov, C = C, n = n)
}

test_that("discrepancy_posterior() and diagnose_gap() read one law of delta, the Gaussian conditional", {
  lf <- law_fit()
  fit <- lf$fit
  obs <- which(!is.na(lf$toy$y))
  a <- fit$prior$shape
  b <- fit$prior$rate
  for (g in which(fit$grid$delta_ratio > 0)) for (i in c(2L, 5L)) {
    want <- brute_conditional(lf, i, g)
    # tau integrated out: delta's scale per unit of the law's covariance
    v <- (b + want$C / 2) / (a + want$n / 2)
    v_cell <- v[lf$groups]
    # discrepancy_posterior()'s moments: every draw at (i, g) with tau = 1 / v
    at_ig <- fit
    at_ig$draws <- fit$draws[rep(1, 3), ]
    at_ig$draws$run <- i
    at_ig$draws$grid_point <- g
    at_ig$draws[tau_columns(fit)] <- as.list(1 / v)
    moments <- discrepancy_moments(at_ig)
    expect_equal(moments$mean, want$mean, tolerance = 1e-9)
    expect_equal(moments$sd, sqrt(diag(want$cov) * v_cell), tolerance = 1e-9)
    # diagnose_gap()'s discrepancy_where(): the exact posterior all at (i, g),
    # one block per x setting
    joint <- matrix(0, nrow(lf$toy$Y), n_grid_points(fit$setup))
    joint[i, g] <- 1
    where <- discrepancy_where(fit, list(joint = joint), list(1:5), fdr = 0.1, found = TRUE)
    expect_equal(where$map$residual[obs], want$mean[obs], tolerance = 1e-9)
    expect_true(all(is.na(where$map$residual[-obs])))
    expect_equal(where$map$z[obs], want$mean[obs] / sqrt(diag(want$cov)[obs] * v_cell[obs]),
                 tolerance = 1e-7)
    # ... and the two readers agree: the same mean, the same mean / sd
    expect_equal(where$map$residual[obs], moments$mean[obs], tolerance = 1e-9)
    expect_equal(where$map$z[obs], moments$mean[obs] / moments$sd[obs], tolerance = 1e-7)
    # a block's statistic: sum over its noise groups of m_B' P_B^-1 m_B / v,
    # over the block's size
    for (x in 1:3) {
      cells <- intersect(obs, (x - 1L) * 5L + 1:5)
      tt <- sum(vapply(split(cells, lf$groups[cells]), function(B) {
        P <- want$cov[B, B, drop = FALSE]
        expect_lt(kappa(P, exact = TRUE), 1e6)          # full rank: no pseudo-inverse
        sum(want$mean[B] * solve(P, want$mean[B])) / v[lf$groups[B[1]]]
      }, numeric(1)))
      expect_equal(where$blocks$score[x], tt / length(cells), tolerance = 1e-6)
    }
  }
})

test_that("delta's law is NULL at lambda = 0 and restricts to the observed outputs on request", {
  lf <- law_fit()
  fit <- lf$fit
  kernels <- fit_kernels(fit)
  expect_null(delta_law(fit$setup, which(fit$grid$delta_ratio == 0)[1], kernels))
  g <- which(fit$grid$delta_ratio > 0)[1]
  all <- delta_law(fit$setup, g, kernels)
  seen <- delta_law(fit$setup, g, kernels, observed_only = TRUE)
  obs <- which(!is.na(lf$toy$y))
  expect_identical(sort(unlist(lapply(all$groups, `[[`, "cells"))), 1:15)
  expect_identical(sort(unlist(lapply(seen$groups, `[[`, "cells"))), obs)
  resid <- run_residuals(fit, 4)
  m_all <- delta_means(all, resid)
  m_seen <- delta_means(seen, resid)
  expect_equal(m_seen[, obs], m_all[, obs], tolerance = 1e-12)
  expect_identical(m_seen[, -obs], numeric(15 - length(obs)))
  for (k in seq_along(all$groups)) {
    keep <- match(seen$groups[[k]]$cells, all$groups[[k]]$cells)
    expect_equal(delta_cov(seen$groups[[k]]), delta_cov(all$groups[[k]])[keep, keep],
                 tolerance = 1e-12)
    expect_equal(delta_cov_diag(all$groups[[k]]), pmax(diag(delta_cov(all$groups[[k]])), 0),
                 tolerance = 1e-12)
  }
})

test_that("a low-rank fit's law needs no dense kernels: the same law from the factors", {
  fit <- law_fit()$fit
  expect_true(fit$setup$dense$lowrank)
  expect_null(fit_kernels(fit))
  K <- discrepancy_kernels(fit$library, attr(fit$setup$discrepancy, "kernels"))
  positive <- which(fit$grid$delta_ratio > 0)
  for (g in positive[c(1, length(positive))]) {
    expect_identical(delta_law(fit$setup, g, NULL)$groups, delta_law(fit$setup, g, K)$groups)
  }
})
