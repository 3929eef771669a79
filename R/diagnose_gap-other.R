# "other": the base model plus a generic smooth discrepancy (see ?diagnose_gap).

# Squared-exponential correlation over the scaled (x, t), length-scale `scale`.
smooth_kernel <- function(ctx, scale) {
  xs <- if (is.null(ctx$x)) matrix(0, 1, 1) else apply(as.matrix(ctx$x), 2, scale_unit)
  xs <- matrix(xs, nrow = ctx$n_x)
  Kx <- exp(-as.matrix(stats::dist(xs))^2 / scale^2)
  ts <- scale_unit(ctx$t)
  Kt <- exp(-outer(ts, ts, "-")^2 / scale^2)
  kronecker(Kx, Kt)
}

# "other": y = eta(theta) + delta + e, delta ~ N(0, s tau^-1 K_l) a smooth
# discrepancy with variance s times the noise's, e ~ N(0, tau^-1 R_g).
# Evidence over runs x correlation nodes x scales x variance ratios.
other_log_evidence <- function(ctx, base_terms, scales, ratios = 4^(1:4)) {
  n <- ctx$n
  Et <- t(base_terms$E[, ctx$obs, drop = FALSE])
  # with relative sd the discrepancy stays smooth in output units (S K S would
  # not be): its variance is s times the mean noise variance over the data
  sd2 <- if (is.null(ctx$sd)) 1 else mean(ctx$sd[ctx$obs]^2)
  kernels <- lapply(scales, function(sc) smooth_kernel(ctx, sc))
  # a kernel that does not correlate neighbouring points is white noise, which
  # the noise model already has (with tau integrated out it is the base model)
  smooth <- vapply(kernels, function(K) {
    diag(K) <- 0
    stats::median(apply(K, 1, max)) >= 0.5
  }, logical(1))
  kernels <- if (any(smooth)) kernels[smooth] else kernels[which.max(scales)]
  kernels <- lapply(kernels, function(K) sd2 * K[ctx$obs, ctx$obs, drop = FALSE])
  pieces <- unlist(lapply(kernels, function(K) {
    unlist(lapply(ctx$points, function(point) {
      R <- point_covariance(ctx, point)
      vapply(ratios, function(s) {
        L <- chol(R + s * K)
        Q <- matrix(colSums(backsolve(L, Et, transpose = TRUE)^2))
        log_sum_exp(collapsed_log_joint(Q, n, 2 * sum(log(diag(L))), ctx$prior,
                                        base_terms$log_prior_run, point$log_prior))
      }, numeric(1))
    }))
  }))
  log_sum_exp(pieces) - log(length(kernels) * length(ratios))
}
