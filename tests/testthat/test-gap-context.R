test_that("the whitened quadratic forms and evidence match the fit's", {
  toy <- toy_gap(0.2, rho_t = c(0, 0.3))
  ctx <- gap_context(toy$fit)
  tm <- gap_terms(ctx, toy$lib$y, toy$fit$log_prior_run)
  expect_equal(tm$Q, toy$fit$C, tolerance = 1e-10)
  ex <- posterior_exact(toy$lib, toy$field, rho_t = c(0, 0.3))
  expect_equal(log_sum_exp(tm$lj), ex$log_evidence, tolerance = 1e-10)
})

test_that("over the observed points, Q, evidence and leave-out pieces are the dense algebra's", {
  toy <- toy_gap(0.2, rho_t = c(0, 0.3), missing = gap_missing, rel_sd = gap_rel_sd)
  ctx <- gap_context(toy$fit)
  tm <- gap_terms(ctx, toy$lib$y, toy$fit$log_prior_run)
  expect_equal(tm$Q, toy$fit$C, tolerance = 1e-10)
  ex <- posterior_exact(toy$lib, toy$field, rho_t = c(0, 0.3))
  expect_equal(log_sum_exp(tm$lj), ex$log_evidence, tolerance = 1e-10)
  y <- as.vector(t(toy$field$y))
  obs <- which(!is.na(y))
  for (g in 1:2) {
    R <- kronecker(diag(3), corr_t(toy$t, c(0, 0.3)[g])) * outer(gap_rel_sd, gap_rel_sd)
    P <- solve(R[obs, obs])
    for (k in 1:3) {
      B <- which(obs %in% ((k - 1) * 30 + 1:30))
      D <- vapply(seq_len(nrow(toy$lib$y)), function(j) {
        h <- P %*% (y - toy$lib$y[j, ])[obs]
        drop(t(h[B]) %*% solve(P[B, B], h[B]))
      }, numeric(1))
      expect_equal(tm$D[, g, k], D, tolerance = 1e-8)
    }
  }
})

test_that("the AR(1) precision is the whitening operator's A'A, filled in O(n_t)", {
  set.seed(4)
  for (n_t in c(1, 2, 5, 30)) {
    for (phi in list(rep(0, n_t - 1), runif(n_t - 1, 0, 0.95))) {
      A <- t(ar1_whiten_rows_cpp(diag(n_t), phi, 1L))
      Pt <- ar1_precision(phi, n_t)
      expect_equal(Pt[seq_len(n_t), seq_len(n_t), drop = FALSE], crossprod(A), tolerance = 1e-13)
      expect_equal(ar1_precision_times(Pt, diag(n_t)), crossprod(A), tolerance = 1e-13)
    }
  }
})

test_that("products with the precision, one vector or many, are the dense ones", {
  toy <- toy_gap(0.2, rho_t = c(0, 0.5))
  ctx <- gap_context(toy$fit)
  set.seed(5)
  M <- matrix(rnorm(90 * 4), 90)
  for (point in ctx$points) {
    P <- kronecker(point$Rx_inv, point$Pt)
    expect_equal(apply_precision(ctx, point, M[, 1]), drop(P %*% M[, 1]), tolerance = 1e-12)
    expect_equal(precision_times(ctx, point, M), P %*% M, tolerance = 1e-12)
  }
  # and with correlation across settings
  point <- ctx$points[[2]]
  point$Rx_inv <- solve(matrix(c(1, 0.5, 0.2, 0.5, 1, 0.5, 0.2, 0.5, 1), 3))
  P <- kronecker(point$Rx_inv, point$Pt)
  expect_equal(precision_times(ctx, point, M), P %*% M, tolerance = 1e-12)
})

test_that("leave-setting-out pieces in closed form are the whitened ones", {
  toy <- toy_gap(0.2, rho_t = c(0, 0.3, 0.6))
  ctx <- gap_context(toy$fit)
  expect_true(settings_apart(ctx))
  E <- rep(ctx$y, each = nrow(toy$lib$y)) - toy$lib$y
  D <- setting_quad_forms(ctx, toy$lib$y)
  for (g in seq_along(ctx$points)) {
    expect_equal(D[, g, ], setting_pieces(ctx, E, ctx$points[[g]]), tolerance = 1e-11)
  }
  # correlation across settings: the settings are not apart, the whitened path
  ctx$points[[2]]$Rx_inv <- solve(matrix(c(1, 0.5, 0.2, 0.5, 1, 0.5, 0.2, 0.5, 1), 3))
  expect_false(settings_apart(ctx))
  expect_false(settings_apart(gap_context(
    toy_gap(0.2, missing = gap_missing, rel_sd = gap_rel_sd)$fit)))
})

test_that("a model's rows shared with another take its leave-out pieces", {
  toy <- toy_gap(0.2, rho_t = c(0, 0.3))
  ctx <- gap_context(toy$fit)
  base <- gap_terms(ctx, toy$lib$y, toy$fit$log_prior_run)
  Y <- rbind(toy$lib$y, lib_outputs(toy$quad))
  prior <- rep(-log(nrow(Y)), nrow(Y))
  whole <- gap_terms(ctx, Y, prior)
  # Y holds only the rows after the shared ones
  shared <- gap_terms(ctx, lib_outputs(toy$quad), prior, shared = base)
  expect_identical(shared$D[seq_len(nrow(toy$lib$y)), , ], base$D)
  expect_equal(shared$D, whole$D, tolerance = 1e-12)
  expect_equal(shared$Q, whole$Q, tolerance = 1e-12)
  expect_equal(shared$lj, whole$lj, tolerance = 1e-12)
  # its outputs read across the two parts as the whole's
  rows <- c(1L, nrow(toy$lib$y), nrow(toy$lib$y) + 1L, nrow(Y), 5L)
  expect_identical(term_outputs(shared, rows, 2:4), Y[rows, 2:4])
})
