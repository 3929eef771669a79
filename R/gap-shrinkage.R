# HOW MUCH: exact leave-one-x-setting-out prediction by the base model and by
# each candidate, without refits (grid reweighting). See ?diagnose_gap.

# `identified`: per candidate, per x setting, whether the fold leaving that
# setting out can learn the candidate's strength (strength_identified()).
gap_folds <- function(ctx, base_terms, cand_terms, identified = NULL) {
  models <- c(list(none = base_terms), cand_terms)
  rows <- lapply(names(models), function(nm) {
    tm <- models[[nm]]
    tm$log_mass <- log_sum_exp(tm$lj_plain)      # log p(y), shared by the folds
    known <- if (nm == "none" || is.null(identified[[nm]])) rep(TRUE, ctx$n_x) else
      identified[[nm]]
    do.call(rbind, lapply(seq_len(ctx$n_x), function(k) {
      fold <- fold_one(ctx, tm, k, nm)
      if (!is.null(fold)) fold$identified <- known[k]
      fold
    }))
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
  # value's noise sd times its relative sd (a replicated cell's mean: that of
  # the mean)
  keep <- top_pairs(w, 0.9999, 500L)
  wk <- w[keep] / sum(w[keep])
  ij <- arrayInd(keep, dim(w))
  nu <- 2 * a + n - m
  scale <- sqrt((b + Qm[keep] / 2) / (a + (n - m) / 2))
  z <- (matrix(y_b, length(keep), m, byrow = TRUE) - term_outputs(tm, ij[, 1], cols)) / scale
  if (!is.null(ctx$sd_y)) z <- sweep(z, 2, ctx$sd_y[cols], "/")
  pit <- colSums(wk * stats::pt(z, nu))
  data.frame(model = model, x = k, n = m, sse = sum((y_b - pred)^2),
             rmse = sqrt(mean((y_b - pred)^2)), lpd = lpd,
             cover90 = mean(pit >= 0.05 & pit <= 0.95), stringsAsFactors = FALSE)
}

# The folds pooled per candidate: `before` and `after` the held-out RMSE,
# `shrink` = 1 - after / before, the summed log predictive densities and the
# coverage of 90% intervals. A candidate with a fold that cannot learn its
# strength (`identified` FALSE in `folds`) has its `after` figures and
# `shrink` withheld (NA): that fold's prediction, and so the pooled figure,
# would be set by the prior over the strength grid, not by the data
# (`unidentified` names the held-out settings, by `labels`).
summarise_folds <- function(folds, candidates, labels = NULL) {
  pooled <- function(nm) {
    f <- folds[folds$model == nm, ]
    c(rmse = sqrt(sum(f$sse) / sum(f$n)), lpd = sum(f$lpd),
      cover = sum(f$cover90 * f$n) / sum(f$n))
  }
  b0 <- pooled("none")
  out <- do.call(rbind, lapply(candidates, function(nm) {
    bk <- pooled(nm)
    f <- folds[folds$model == nm, ]
    lost <- if (is.null(f$identified)) integer(0) else f$x[!f$identified]
    if (length(lost) > 0L) bk[] <- NA_real_
    data.frame(effect = nm, before = b0[["rmse"]], after = bk[["rmse"]],
               shrink = 1 - bk[["rmse"]] / b0[["rmse"]],
               lpd_before = b0[["lpd"]], lpd_after = bk[["lpd"]],
               cover90_before = b0[["cover"]], cover90_after = bk[["cover"]],
               identified = length(lost) == 0L,
               unidentified = paste(if (is.null(labels)) lost else labels[lost],
                                    collapse = "; "),
               stringsAsFactors = FALSE)
  }))
  rownames(out) <- NULL
  out
}

# Whether the fold leaving out each x setting can learn a candidate's strength
# (one logical per setting). With the effect there but not at the other
# settings (an effect that acts at one setting only), the training part of
# that fold is as likely under every strength: the strength's posterior is
# its prior, and the prediction of the held-out setting, so the shrinkage, is
# set by the strength grid. A fold learns the strength when its training
# settings alone could show the candidate's largest effect at the bar a gap
# needs (gap_shown()): the log likelihood ratio of the effect against none
# on the training cells, tau d_-B' Sigma_-B^-1 d_-B / 2 = tau (d'Pd - D_B) /
# 2 (the leave-setting-out identity of setting_pieces(), at the base
# posterior's top grid point `point` and precision `tau`), beyond
# gap_detect_log_odds for some non-zero strength. `pairs` holds, per
# non-zero strength level, the candidate's run near the base posterior mode
# and its zero-strength run (confounding_screen()): d is their difference.
strength_identified <- function(ctx, cand, pairs, point, tau) {
  info <- vapply(pairs, function(pair) {
    d <- lib_outputs(cand, pair[1]) - lib_outputs(cand, pair[2])
    whole <- sum(d[ctx$obs] * apply_precision(ctx, point, d[ctx$obs]))
    tau * pmax(whole - setting_pieces(ctx, d, point)[1, ], 0) / 2
  }, numeric(ctx$n_x))
  apply(matrix(info, ctx$n_x), 1, max) > gap_detect_log_odds
}
