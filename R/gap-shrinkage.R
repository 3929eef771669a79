# HOW MUCH: exact leave-one-x-setting-out prediction by the base model and by
# each candidate, without refits (grid reweighting). See ?diagnose_gap.

gap_folds <- function(ctx, base_terms, cand_terms) {
  models <- c(list(none = base_terms), cand_terms)
  rows <- lapply(names(models), function(nm) {
    tm <- models[[nm]]
    tm$log_mass <- log_sum_exp(tm$lj_plain)      # log p(y), shared by the folds
    do.call(rbind, lapply(seq_len(ctx$n_x), function(k) fold_one(ctx, tm, k, nm)))
  })
  out <- do.call(rbind, rows)
  rownames(out) <- NULL
  out
}

# Leave out the observed cells of x setting k (NULL when it has none: there is
# nothing to predict).
fold_one <- function(ctx, tm, k, model) {
  a <- ctx$prior$shape
  b <- ctx$prior$rate
  n <- ctx$n
  pos <- ctx$setting_pos[[k]]
  m <- length(pos)
  if (m == 0L) return(NULL)
  cols <- ctx$obs[pos]
  # log|R_-B| = log|R_g| + log|(R_g^-1)_BB|: for complete data (R^-1)_BB =
  # (R_x^-1)_kk Pt, otherwise from the point's factor of P_BB
  ld_bb <- vapply(ctx$points, function(point) {
    if (ctx$is_dense) return(2 * sum(log(diag(point$setting_chol[[k]]))))
    m * log(point$Rx_inv[k, k]) - sum(log1p(-point$phi^2))
  }, numeric(1))
  Qm <- pmax(tm$Q - tm$D[, , k], 0)
  # the leave-B-out posterior over (run, grid point) and its log evidence, in
  # passes over Qm (src/exact_posterior.cpp, as grid_posterior())
  post <- grid_posterior_cpp(matrix(Qm, nrow(tm$Q)), a + (n - m) / 2, b, ctx$logdet + ld_bb,
                             tm$log_prior_run, ctx$log_prior_grid, TRUE, griddy_threads())
  lpd <- tm$log_mass - (post$log_norm + log_evidence_constant(ctx$prior, n - m))
  w <- post$joint
  y_b <- ctx$y[cols]
  pred <- term_mean(tm, post$run)[cols]
  # physics-only predictive: simulator at the run plus fitted noise (t), each
  # point's noise sd times its relative sd
  keep <- top_pairs(w, 0.9999, 500L)
  wk <- w[keep] / sum(w[keep])
  ij <- arrayInd(keep, dim(w))
  nu <- 2 * a + n - m
  scale <- sqrt((b + Qm[keep] / 2) / (a + (n - m) / 2))
  z <- (matrix(y_b, length(keep), m, byrow = TRUE) - term_outputs(tm, ij[, 1], cols)) / scale
  if (!is.null(ctx$sd)) z <- sweep(z, 2, ctx$sd[cols], "/")
  pit <- colSums(wk * stats::pt(z, nu))
  data.frame(model = model, x = k, n = m, sse = sum((y_b - pred)^2),
             rmse = sqrt(mean((y_b - pred)^2)), lpd = lpd,
             cover90 = mean(pit >= 0.05 & pit <= 0.95), stringsAsFactors = FALSE)
}

summarise_folds <- function(folds, candidates) {
  pooled <- function(nm) {
    f <- folds[folds$model == nm, ]
    c(rmse = sqrt(sum(f$sse) / sum(f$n)), lpd = sum(f$lpd),
      cover = sum(f$cover90 * f$n) / sum(f$n))
  }
  b0 <- pooled("none")
  out <- do.call(rbind, lapply(candidates, function(nm) {
    bk <- pooled(nm)
    data.frame(effect = nm, before = b0[["rmse"]], after = bk[["rmse"]],
               shrink = 1 - bk[["rmse"]] / b0[["rmse"]],
               lpd_before = b0[["lpd"]], lpd_after = bk[["lpd"]],
               cover90_before = b0[["cover"]], cover90_after = bk[["cover"]],
               stringsAsFactors = FALSE)
  }))
  rownames(out) <- NULL
  out
}
