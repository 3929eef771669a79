# CONFOUNDING WITH THETA: whether a shift of theta imitates a candidate's
# effect (see ?diagnose_gap, Confounding).

confounding_screen <- function(ctx, base_terms, cand, base_cols, threshold, effect,
                               white = screen_white(ctx, base_terms)) {
  top <- white$top
  point <- white$point
  tau_hat <- (ctx$prior$shape + ctx$n / 2) / (ctx$prior$rate + base_terms$Q[top[1], top[2]] / 2)
  theta_b <- as.matrix(ctx$theta[base_cols])
  lo <- apply(theta_b, 2, min)
  span <- pmax(apply(theta_b, 2, max) - lo, 1e-300)
  sc <- function(m) sweep(sweep(as.matrix(m), 2, lo, "-"), 2, span, "/")
  tb <- sc(theta_b)
  tc <- sc(lib_theta(cand)[base_cols])
  strength <- as.matrix(lib_theta(cand)[setdiff(names(lib_theta(cand)), base_cols)])
  level <- strength_levels(strength)
  zero <- rowSums(abs(strength)) == 0
  Wb <- white$rows
  near <- function(from, pool) pool[which.min(colSums((t(tc[pool, , drop = FALSE]) - from)^2))]
  m <- min(nrow(tb) - 2L, 3L * ncol(tb) + 3L)
  # the part of output w that no base run (best one, refined linearly on its
  # theta neighbours) reproduces, leaving out base run `drop`
  imitate <- function(w, drop = 0L) {
    j <- nearest_row(NULL, w, white$norm2, drop, rows = Wb, dot = white$dot)
    dist <- colSums((t(tb) - tb[j, ])^2)
    dist[c(j, drop)] <- Inf
    nb <- order(dist)[seq_len(m)]
    wj <- drop(Wb(j))
    Dm <- t(sweep(Wb(nb), 2, wj, "-"))
    list(e = sqrt(sum(stats::lm.fit(Dm, w - wj)$residuals^2)), j = j, nb = nb)
  }
  # the library's own resolution: how well the other runs imitate runs near the
  # mode (the same for every candidate: computed for the first, kept in `white`)
  e_grid <- white$kept$e_grid
  if (is.null(e_grid)) {
    around <- order(colSums((t(tb) - tb[top[1], ])^2))[seq_len(min(5L, nrow(tb) - m - 1L))]
    e_grid <- sqrt(mean(vapply(around, function(j) imitate(drop(Wb(j)), j)$e^2, numeric(1))))
    white$kept$e_grid <- e_grid
  }
  res <- lapply(setdiff(unique(level), unique(level[zero])), function(lv) {
    i1 <- near(tb[top[1], ], which(level == lv))
    i0 <- near(tc[i1, ], which(zero))
    w <- whiten_rows(lib_outputs(cand, c(i1, i0)), point, ctx$n_x, ctx$n_t)
    delta <- sqrt(sum((w[1, ] - w[2, ])^2))
    im <- imitate(w[1, ])
    shift <- abs(tb[im$j, ] - tc[i0, ])
    list(pair = c(i1, i0), imitator = im[c("j", "nb")], separable = sqrt(max(im$e^2 - e_grid^2, 0)) / max(delta, 1e-300),
         judged = delta > 3 * e_grid, detectable = im$e * sqrt(tau_hat),
         absorbed_by = base_cols[which.max(shift)], strength_size = sum(abs(strength[i1, ])))
  })
  judged <- vapply(res, `[[`, logical(1), "judged")
  sep <- vapply(res, `[[`, numeric(1), "separable")
  biggest <- which.max(vapply(res, `[[`, numeric(1), "strength_size"))
  best <- if (any(judged)) which(judged)[which.min(sep[judged])] else biggest
  absorbed_by <- res[[best]]$absorbed_by
  list(separable = if (any(judged)) sep[best] else NA_real_,
       confounded = any(judged) && sep[best] < threshold,
       detectable = res[[biggest]]$detectable, absorbed_by = absorbed_by,
       separation = effect_separation(ctx, base_terms$Y, cand, res[[best]]$pair,
                                      res[[best]]$imitator, absorbed_by, effect),
       # which held-out folds can learn the strength (gap-shrinkage.R)
       identified = strength_identified(ctx, cand, lapply(res, `[[`, "pair"), point, tau_hat))
}

# The base runs' outputs whitened at the base posterior's top grid point, as
# the screen reads them: `rows(i)` the whitened rows i, `dot(w)` every
# whitened run's product with w, and `norm2` their squared norms, the same
# for every candidate's screen, so diagnose_gap() computes them once; `kept`
# holds what the first screen computes for all of them (the library's own
# resolution).
# Whitening is linear, Wb = Y A' with A' the whitened identity, so only the
# few rows the screen looks at are whitened: the products with all runs are
# Y (A' w), and the norms are the runs' quadratic forms y_j' P y_j (the
# compiled misfit with zero field data), not a whitened copy of the library.
screen_white <- function(ctx, base_terms) {
  top <- arrayInd(which.max(base_terms$lj), dim(base_terms$lj))
  point <- ctx$points[[top[2]]]
  Y <- base_terms$Y
  At <- whiten_rows(diag(ctx$n_x * ctx$n_t), point, ctx$n_x, ctx$n_t)
  zero <- ctx$y
  zero[!is.na(zero)] <- 0
  list(top = top, point = point, norm2 = plain_quad_forms(Y, zero, ctx$setup)[, top[2]],
       kept = new.env(parent = emptyenv()),
       rows = function(i) Y[i, , drop = FALSE] %*% At,
       dot = function(w) drop(Y %*% (At %*% w)))
}

# The row of W nearest w (squared distance), not row `drop`: |W_j|^2 - 2 W_j'w
# over all rows (one product), then the exact distance among the rows within
# rounding of the least, so that the choice is that of the exact distances.
#
# `rows(i)` and `dot(w)` give W's rows i and W w where W is not held whole
# (screen_white()).
nearest_row <- function(W, w, norm2, drop = 0L, rows = function(i) W[i, , drop = FALSE],
                        dot = function(w) drop(W %*% w)) {
  d2 <- norm2 - 2 * dot(w) + sum(w * w)
  d2[drop] <- Inf
  slack <- 1e-9 * (max(norm2) + sum(w * w))
  close <- which(d2 <= min(d2) + slack)
  exact <- colSums((t(rows(close)) - w)^2)
  close[which.min(exact)]
}
