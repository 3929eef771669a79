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
  stat <- matrix(0, nrow(pairs), nb)
  pval <- matrix(0, nrow(pairs), nb)
  lcond <- matrix(0, nrow(pairs), nb)                    # log p(y_B | y_-B, pair)
  a <- ctx$prior$shape
  b <- ctx$prior$rate
  n <- ctx$n
  for (g in unique(pairs[, 2])) {
    node <- ctx$nodes[[g]]
    at <- which(pairs[, 2] == g)
    chols <- lapply(seq_len(nb), function(i) {
      W <- win[[blocks$w[i]]]
      chol(node$Rx_inv[blocks$x[i], blocks$x[i]] * node$Pt[W, W, drop = FALSE])
    })
    for (p in at) {
      j <- pairs[p, 1]
      Em <- matrix(tm$E[j, ], n_t, ctx$n_x)
      H <- node$Pt %*% Em %*% node$Rx_inv
      Q <- tm$Q[j, g]
      for (i in seq_len(nb)) {
        W <- win[[blocks$w[i]]]
        U <- chols[[i]]
        z <- backsolve(U, H[W, blocks$x[i]], transpose = TRUE)
        D <- sum(z^2)
        m <- length(W)
        rest <- max(2 * b + Q - D, 1e-300)
        nu <- 2 * a + n - m
        f <- (D / m) / (rest / nu)
        stat[p, i] <- f
        pval[p, i] <- stats::pf(f, m, nu, lower.tail = FALSE)
        # log p(y_B | y_-B) = log p(y) - log p(y_-B) at this (run, grid point);
        # |R_-B| = |R| |(R^-1)_BB|
        lcond[p, i] <- collapsed_log_lik(Q, n, 0, ctx$prior) -
          collapsed_log_lik(rest - 2 * b, n - m, 2 * sum(log(diag(U))), ctx$prior)
      }
    }
  }
  # exact leave-block-out weights: w^(-B) proportional to w / p(y_B | y_-B)
  lw <- log(wp) - lcond
  wb <- exp(sweep(lw, 2, apply(lw, 2, max), "-"))
  wb <- sweep(wb, 2, colSums(wb), "/")
  score <- colSums(wb * stat)
  p_value <- colSums(wb * pval)
  t_of <- function(f) vapply(blocks$w, function(k) f(ctx$t[win[[k]]]), numeric(1))
  out <- data.frame(x = blocks$x, from = t_of(min), to = t_of(max),
                    n = vapply(win, length, integer(1))[blocks$w],
                    score = score, p_value = p_value,
                    flagged = stats::p.adjust(p_value, "BH") <= fdr)
  list(blocks = out, map = gap_map(ctx, tm, w), breaks = win)
}

# Indices of the largest weights holding `mass` of the total (at most `cap`).
top_pairs <- function(w, mass, cap) {
  o <- order(w, decreasing = TRUE)
  k <- which(cumsum(w[o]) >= mass * sum(w))[1]
  o[seq_len(min(cap, k))]
}

# Windows over t as lists of indices: at least one fitted correlation length.
gap_windows <- function(ctx, tm, windows) {
  n_t <- ctx$n_t
  split_equal <- function(m) {
    m <- max(1L, min(m, n_t))
    unname(split(seq_len(n_t), ceiling(seq_len(n_t) * m / n_t)))
  }
  if (is.null(windows)) {
    if (n_t == 1L) return(list(1L))
    g <- arrayInd(which.max(tm$lj), dim(tm$lj))[2]
    phi <- ctx$nodes[[g]]$phi
    # correlation length in samples: lag at which the correlation falls to 1/e
    lag1 <- stats::median(phi)
    len <- if (lag1 <= 0) 1 else -1 / log(lag1)
    return(split_equal(min(8L, floor(n_t / max(len, 1, na.rm = TRUE)))))
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

# Posterior-mean residual field of the base model and its size in noise sds.
gap_map <- function(ctx, tm, w) {
  wr <- rowSums(w)
  resid <- colSums(tm$E * wr)
  sigma <- sqrt(sum(w * (ctx$prior$rate + tm$Q / 2) / (ctx$prior$shape + ctx$n / 2)))
  data.frame(x = rep(seq_len(ctx$n_x), each = ctx$n_t), t = rep(ctx$t, ctx$n_x),
             residual = resid, z = resid / sigma)
}
