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
