# WHERE: exact leave-block-out predictive checks of the fitted (base) model,
# one block per x setting and window of t. See ?diagnose_gap.

gap_where <- function(ctx, tm, windows, fdr) {
  win <- gap_windows(ctx, tm, windows)
  w <- normalise_log(tm$lj)
  pairs <- top_pairs(w, 0.999, 200L)
  wp <- w[pairs] / sum(w[pairs])
  pairs <- arrayInd(pairs, dim(w))
  n_t <- ctx$n_t
  blocks <- expand.grid(w = seq_along(win), x = seq_len(ctx$n_x))
  nb <- nrow(blocks)
  # each block's observed cells, as positions in the data vector; a block
  # with none is not checked (NA score and p-value, n = 0)
  pos <- lapply(seq_len(nb), function(i) {
    block_positions(ctx$obs, blocks$x[i], win[[blocks$w[i]]], n_t)
  })
  size <- lengths(pos)
  checked <- which(size > 0L)
  np <- nrow(pairs)
  # per pair and block: D = the held-out block's squared predictive residual
  # (in its predictive precision), log|(S^-1)_BB|; per pair: Q and log|S|
  D <- matrix(NA_real_, np, nb)
  logdet_BB <- matrix(NA_real_, np, nb)
  Q <- numeric(np)
  logdet <- numeric(np)
  for (g in unique(pairs[, 2])) {
    point <- ctx$points[[g]]
    at <- which(pairs[, 2] == g)
    P_BB <- lapply(seq_len(nb), function(i) {
      if (size[i] > 0L) block_precision(ctx, point, pos[[i]], win[[blocks$w[i]]], blocks$x[i])
    })
    chols <- lapply(P_BB, function(S) if (!is.null(S)) chol(S))
    H <- matrix(0, length(at), length(ctx$obs))
    plain <- logical(length(at))
    if (is.null(tm$emulation)) {
      # every run simulated: h = R_g^-1 e for all of them at once (the loop
      # below, one run at a time, took a third of the gap screen)
      js <- pairs[at, 1]
      H <- precision_rows(ctx, point, rep(ctx$y[ctx$obs], each = length(js)) -
                            tm$Y[js, ctx$obs, drop = FALSE])
      plain[] <- TRUE
      Q[at] <- tm$Q[cbind(js, g)]
    }
    for (k in seq_along(at)[!plain]) {
      j <- pairs[at[k], 1]
      e <- ctx$y[ctx$obs] - tm$Y[j, ctx$obs]
      # the run's index in its library (terms of some runs keep it in `rows`)
      err <- run_emulation(tm$emulation, if (is.null(tm$rows)) j else tm$rows[j], ctx$obs)
      if (is.null(err)) {
        plain[k] <- TRUE
        H[k, ] <- apply_precision(ctx, point, e)
        Q[at[k]] <- tm$Q[j, g]
        next
      }
      wood <- emulated_inverse(ctx, point, e, err)
      Q[at[k]] <- wood$Q
      logdet[at[k]] <- wood$logdet
      for (i in checked) {
        bs <- emulated_block(wood, P_BB[[i]], pos[[i]])
        D[at[k], i] <- bs$D
        logdet_BB[at[k], i] <- bs$logdet_BB
      }
    }
    # the simulated runs at this point share R_g: every block at once
    if (any(plain)) {
      Hp <- t(H[plain, , drop = FALSE])
      for (i in checked) {
        z <- backsolve(chols[[i]], Hp[pos[[i]], , drop = FALSE], transpose = TRUE)
        D[at[plain], i] <- colSums(z^2)
        logdet_BB[at[plain], i] <- 2 * sum(log(diag(chols[[i]])))
      }
    }
  }
  a <- ctx$prior$shape
  b <- ctx$prior$rate
  n <- ctx$n
  m <- matrix(size, np, nb, byrow = TRUE)
  rest <- pmax(2 * b + Q - D, 1e-300)
  nu <- 2 * a + n - m
  stat <- (D / m) / (rest / nu)
  pval <- stats::pf(stat, m, nu, lower.tail = FALSE)
  # log p(y_B | y_-B) = log p(y) - log p(y_-B) at each (run, grid point),
  # up to a constant of the block (its size's), which the weights' own
  # normalisation takes out; |S_-B| = |S| |(S^-1)_BB|, with S the run's
  # covariance relative to R_g
  lcond <- -(a + n / 2) * log(b + Q / 2) - logdet / 2 +
    (a + (n - m) / 2) * log(rest / 2) + (logdet + logdet_BB) / 2
  lcond[, -checked] <- 0
  # exact leave-block-out weights: w^(-B) proportional to w / p(y_B | y_-B)
  lw <- log(wp) - lcond
  wb <- exp(sweep(lw, 2, apply(lw, 2, max), "-"))
  wb <- sweep(wb, 2, colSums(wb), "/")
  score <- colSums(wb * stat)
  p_value <- colSums(wb * pval)
  t_of <- function(f) vapply(blocks$w, function(k) f(ctx$t[win[[k]]]), numeric(1))
  flagged <- stats::p.adjust(p_value, "BH") <= fdr
  flagged <- distinct_flags(flagged & !is.na(flagged), p_value, blocks, win)
  out <- data.frame(x = blocks$x, from = t_of(min), to = t_of(max), n = size,
                    score = score, p_value = p_value, flagged = flagged)
  list(blocks = out, map = gap_map(ctx, tm, w), breaks = win)
}

# h = P e for the data vector e: P = R_x^-1 (x) Pt for complete data, the
# point's dense P otherwise.
apply_precision <- function(ctx, point, e) {
  if (ctx$is_dense) return(drop(point$P %*% e))
  as.vector(ar1_precision_times(point$Pt, matrix(e, ctx$n_t, ctx$n_x)) %*% point$Rx_inv)
}

# apply_precision() of every row of E (runs x data points) at once: E P for
# the point's dense P (symmetric); otherwise each run's t x x block B becomes
# Pt B R_x^-1, Pt over all blocks side by side, R_x^-1 over all runs' rows.
precision_rows <- function(ctx, point, E) {
  if (ctx$is_dense) return(E %*% point$P)
  n_t <- ctx$n_t
  n_x <- ctx$n_x
  runs <- nrow(E)
  B <- ar1_precision_times(point$Pt, matrix(t(E), n_t))             # n_t x (n_x runs)
  B <- aperm(array(B, c(n_t, n_x, runs)), c(1L, 3L, 2L))            # n_t x runs x n_x
  B <- array(matrix(B, n_t * runs) %*% point$Rx_inv, c(n_t, runs, n_x))
  t(matrix(aperm(B, c(1L, 3L, 2L)), n_t * n_x))
}

# Pt X for the tridiagonal AR(1) precision Pt (ar1_precision()), in O(n_t)
# per column of X.
ar1_precision_times <- function(Pt, X) {
  n_t <- nrow(X)
  out <- attr(Pt, "diag") * X
  if (n_t == 1L) return(out)
  off <- attr(Pt, "off") * X[-1, , drop = FALSE]           # (Pt)_(i,i+1) x_(i+1)
  out[-n_t, ] <- out[-n_t, ] + off
  out[-1, ] <- out[-1, ] + attr(Pt, "off") * X[-n_t, , drop = FALSE]
  out
}

# P_BB for the block of setting x and t indices W at data positions `pos`.
block_precision <- function(ctx, point, pos, W, x) {
  if (ctx$is_dense) return(point$P[pos, pos, drop = FALSE])
  point$Rx_inv[x, x] * point$Pt[W, W, drop = FALSE]
}

# Indices of the largest weights holding `mass` of the total (at most `cap`).
top_pairs <- function(w, mass, cap) {
  # only the `cap` largest can be chosen: order those (a partial sort finds
  # them), the same indices in the same order as ordering all of w
  if (length(w) > cap) {
    # the entries within 1e-6 of the largest hold the `cap` largest when
    # there are that many (a posterior's mass rests on few): sort those only
    pool <- which(w >= max(w) * 1e-6)
    if (length(pool) < cap) pool <- seq_along(w)
    least <- -sort(-w[pool], partial = cap)[cap]
    pool <- pool[w[pool] >= least]
  } else {
    pool <- seq_along(w)
  }
  o <- pool[order(w[pool], decreasing = TRUE)]
  k <- which(cumsum(w[o]) >= mass * sum(w))[1]
  if (is.na(k)) k <- length(o)
  o[seq_len(min(cap, k))]
}

# Windows over t as lists of indices. Given `windows` (a count or breaks),
# they tile t. By default they scan it (scan_windows(); `scan = FALSE`: the
# tiling alone, for where a discrepancy lies): from one fitted correlation
# length up to the tiling's width (at most 8 windows, each at least one
# correlation length), each width at steps of half its length.
gap_windows <- function(ctx, tm, windows, scan = TRUE) {
  n_t <- ctx$n_t
  split_equal <- function(m) {
    m <- max(1L, min(m, n_t))
    unname(split(seq_len(n_t), ceiling(seq_len(n_t) * m / n_t)))
  }
  if (is.null(windows)) {
    if (n_t == 1L) return(list(1L))
    g <- arrayInd(which.max(tm$lj), dim(tm$lj))[2]
    phi <- ctx$points[[g]]$phi
    # correlation length in samples: lag at which the correlation falls to 1/e
    lag1 <- stats::median(phi)
    len <- if (lag1 <= 0) 1 else -1 / log(lag1)
    len <- max(len, 1, na.rm = TRUE)
    tiling <- split_equal(min(8L, floor(n_t / len)))
    if (!scan) return(tiling)
    return(scan_windows(n_t, ceiling(len), max(lengths(tiling))))
  }
  windows <- assert_numeric_vector(windows, "windows")
  if (length(windows) == 1L) {
    if (windows != round(windows) || windows < 1) {
      griddy_abort("`windows` as a single value must be a whole number of windows >= 1; ",
                   "received ", windows, ".")
    }
    return(split_equal(as.integer(windows)))
  }
  br <- sort(unique(windows))
  idx <- findInterval(ctx$t, br, rightmost.closed = TRUE)
  keep <- idx >= 1L & idx < length(br)
  if (!any(keep)) {
    griddy_abort("`windows` breaks (", show_some(br), ") cover none of t (",
                 format(min(ctx$t)), " to ", format(max(ctx$t)), ").")
  }
  unname(split(seq_len(n_t)[keep], idx[keep]))
}

# The default windows: a multiscale scan of indices 1..n_t, widths doubling
# from `narrow` up to `widest` (which is always one), each width at steps of
# half its length (the last window ending at n_t). A local misfit then falls
# inside a window about its own size wherever it sits: the fixed tiling this
# replaces split a second peak between two windows, and missed it in 6 of 45
# trials at 5 noise sds (bench/gap-signal.R). The windows overlap, and
# Benjamini-Hochberg runs over all of them: on data without a gap it is
# Simes' test that no block misfits, which holds its level under positive
# dependence (overlapping windows share cells; measured: 1 false alarm in 90
# and in 30 trials on two systems, bench/gap-signal*.R), and the scan costs
# a single misfit's statistic a critical value that grows as the log of the
# number of windows, not as the number.
scan_windows <- function(n_t, narrow, widest) {
  narrow <- min(narrow, widest)
  widths <- unique(c(narrow * 2^(0:floor(log2(widest / narrow))), widest))
  widths <- widths[widths <= widest]
  out <- list()
  for (w in widths) {
    step <- max(1L, floor(w / 2))
    starts <- unique(c(seq(1L, max(1L, n_t - w + 1L), by = step), max(1L, n_t - w + 1L)))
    out <- c(out, lapply(starts, function(s) seq.int(s, min(n_t, s + w - 1L))))
  }
  out
}

# Flags `flagged` of overlapping blocks reduced to one per place: among the
# flagged blocks of a setting, the one with the smallest p-value is kept and
# those sharing a point of t with it are dropped, then the next. (Disjoint
# blocks, a tiling, are left as they are.) A count of flagged blocks is a
# count of places.
distinct_flags <- function(flagged, p_value, blocks, win) {
  keep <- logical(length(flagged))
  for (i in which(flagged)[order(p_value[flagged])]) {
    same <- which(keep & blocks$x == blocks$x[i])
    clash <- any(vapply(same, function(k) any(win[[blocks$w[k]]] %in% win[[blocks$w[i]]]),
                        logical(1)))
    if (!clash) keep[i] <- TRUE
  }
  keep
}

# Posterior-mean residual field of the base model and its size in noise sds
# (each value's own: relative sd, replicated cell means); NA at missing
# cells.
gap_map <- function(ctx, tm, w) {
  wr <- rowSums(w)
  # sum_j wr_j (y - Y_j), without the runs x data points residuals
  resid <- ctx$y * sum(wr) - term_mean(tm, wr)
  sigma <- sqrt(sum(w * (ctx$prior$rate + tm$Q / 2) / (ctx$prior$shape + ctx$n / 2)))
  # each value's own sd: a replicated cell's mean has 1 / sqrt(n_rep) of a
  # measurement's (scaled by one measurement's, its z was too small)
  if (!is.null(ctx$sd_y)) sigma <- sigma * ctx$sd_y
  data.frame(x = rep(seq_len(ctx$n_x), each = ctx$n_t), t = rep(ctx$t, ctx$n_x),
             residual = resid, z = resid / sigma)
}
