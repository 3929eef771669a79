test_that("'other' is the exact evidence of base model plus a smooth Gaussian discrepancy", {
  toy <- toy_gap(0.1, n_t = 8, rho_t = c(0, 0.4))
  ctx <- gap_context(toy$fit)
  tm <- gap_terms(ctx, toy$lib$y, toy$fit$log_prior_run)
  scales <- c(0.3, 0.001)            # the second is white noise and is dropped
  got <- other_log_evidence(ctx, tm, scales)
  a <- ctx$prior$shape
  b <- ctx$prior$rate
  n <- ctx$n
  y <- as.vector(t(toy$field$y))
  K <- kronecker(exp(-as.matrix(stats::dist(c(0, 0.5, 1)))^2 / 0.09),
                 exp(-outer(toy$t, toy$t, "-")^2 / 0.09))
  terms <- c()
  for (rho in c(0, 0.4)) {
    R <- kronecker(diag(3), corr_t(toy$t, rho))
    for (s in 4^(1:4)) {
      S <- R + s * K
      Si <- solve(S)
      ld <- determinant(S)$modulus[1]
      for (j in seq_len(nrow(toy$lib$y))) {
        r <- y - toy$lib$y[j, ]
        terms <- c(terms, -log(41) - log(2) - log(4) + lgamma(a + n / 2) - lgamma(a) +
                     a * log(b) - n / 2 * log(2 * pi) - ld / 2 -
                     (a + n / 2) * log(b + drop(t(r) %*% Si %*% r) / 2))
      }
    }
  }
  expect_equal(got, log_sum_exp(terms), tolerance = 1e-8)
})

test_that("'other' over the observed points is the exact evidence (discrepancy in output units)", {
  miss <- c(2, 3, 12, 20)
  rs <- 1 + 0.5 * sin(1:24)
  toy <- toy_gap(0.1, n_t = 8, rho_t = c(0, 0.4), missing = miss, rel_sd = rs)
  ctx <- gap_context(toy$fit)
  tm <- gap_terms(ctx, toy$lib$y, toy$fit$log_prior_run)
  got <- other_log_evidence(ctx, tm, 0.3)
  a <- ctx$prior$shape
  b <- ctx$prior$rate
  y <- as.vector(t(toy$field$y))
  obs <- which(!is.na(y))
  n <- length(obs)
  expect_identical(ctx$n, n)
  K <- kronecker(exp(-as.matrix(stats::dist(c(0, 0.5, 1)))^2 / 0.09),
                 exp(-outer(toy$t, toy$t, "-")^2 / 0.09))[obs, obs] * mean(rs[obs]^2)
  terms <- c()
  for (rho in c(0, 0.4)) {
    R <- (kronecker(diag(3), corr_t(toy$t, rho)) * outer(rs, rs))[obs, obs]
    for (s in 4^(1:4)) {
      S <- R + s * K
      Si <- solve(S)
      ld <- determinant(S)$modulus[1]
      for (j in seq_len(nrow(toy$lib$y))) {
        r <- (y - toy$lib$y[j, ])[obs]
        terms <- c(terms, -log(41) - log(2) - log(4) + lgamma(a + n / 2) - lgamma(a) +
                     a * log(b) - n / 2 * log(2 * pi) - ld / 2 -
                     (a + n / 2) * log(b + drop(t(r) %*% Si %*% r) / 2))
      }
    }
  }
  expect_equal(got, log_sum_exp(terms), tolerance = 1e-8)
})

test_that("a smooth kernel's low-rank factor reproduces it, and 'other' stays exact at low rank", {
  toy <- toy_gap(0.1, rho_t = c(0, 0.4))
  ctx <- gap_context(toy$fit)
  K <- smooth_kernel(ctx, 0.3)
  B <- low_rank_factor(K)
  expect_lt(ncol(B), nrow(K))                      # the rank is well below n = 90
  expect_equal(tcrossprod(B), K, tolerance = 1e-10)
  tm <- gap_terms(ctx, toy$lib$y, toy$fit$log_prior_run)
  got <- other_log_evidence(ctx, tm, 0.3)
  y <- as.vector(t(toy$field$y))
  terms <- c()
  for (g in 1:2) {
    R <- kronecker(diag(3), corr_t(toy$t, c(0, 0.4)[g]))
    for (s in 4^(1:4)) {
      L <- chol(R + s * K)
      Q <- colSums(backsolve(L, t(toy$lib$y) - y, transpose = TRUE)^2)
      terms <- c(terms, collapsed_log_joint(matrix(Q), ctx$n, 2 * sum(log(diag(L))), ctx$prior,
                                            tm$log_prior_run, ctx$log_prior_grid[g]))
    }
  }
  expect_equal(got, log_sum_exp(terms) - log(4), tolerance = 1e-8)
})
