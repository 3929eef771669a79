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

test_that("the compiled runs' products of 'other' are the plain products, for every term", {
  set.seed(3)
  n_x <- 3
  n_t <- 7
  J <- 301                                   # blocks and tiles with a remainder
  Y <- matrix(rnorm(J * n_x * n_t), J)
  y <- rnorm(n_x * n_t)
  Mx <- matrix(rnorm(n_x * 5), n_x)          # two x steps: directions 1-3 and 4-5
  terms <- list(list(first = 0L, count = 3L, Mt = matrix(rnorm(n_t * 7), n_t)),
                list(first = 3L, count = 2L, Mt = matrix(rnorm(n_t * 2), n_t)),
                list(first = 0L, count = 3L, Mt = matrix(rnorm(n_t * 13), n_t)))
  Ws <- lapply(terms, function(tm) matrix(runif(tm$count * ncol(tm$Mt) * 2), ncol = 2))
  out <- other_drops_cpp(Y, y, Mx, lapply(terms, `[[`, "Mt"), Ws,
                         vapply(terms, `[[`, integer(1), "first"),
                         vapply(terms, `[[`, integer(1), "count"), 1L)
  E <- rep(y, each = J) - Y
  for (m in seq_along(terms)) {
    tm <- terms[[m]]
    rt <- ncol(tm$Mt)
    want <- matrix(0, J, 2)
    for (ix in seq_len(tm$count)) {
      v <- matrix(E, J * n_t, n_x) %*% Mx[, tm$first + ix]      # E_j Mx, runs x n_t
      Z <- matrix(v, J, n_t) %*% tm$Mt
      want <- want + Z^2 %*% Ws[[m]][(ix - 1) * rt + seq_len(rt), ]
    }
    expect_equal(out[, (m - 1) * 2 + 1:2], want, tolerance = 1e-12)
  }
  # threads do not change a number
  expect_identical(other_drops_cpp(Y, y, Mx, lapply(terms, `[[`, "Mt"), Ws,
                                   vapply(terms, `[[`, integer(1), "first"),
                                   vapply(terms, `[[`, integer(1), "count"), 2L), out)
})
