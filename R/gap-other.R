# "other": the base model plus a generic smooth discrepancy (see ?diagnose_gap).

# Squared-exponential correlation over the scaled (x, t), length-scale `scale`.
smooth_kernel <- function(ctx, scale) {
  parts <- smooth_kernel_parts(ctx, scale)
  kronecker(parts$Kx, parts$Kt)
}

# The kernel's two Kronecker factors, over x settings (Kx) and over t (Kt).
smooth_kernel_parts <- function(ctx, scale) {
  xs <- if (is.null(ctx$x)) matrix(0, 1, 1) else apply(as.matrix(ctx$x), 2, scale_unit)
  xs <- matrix(xs, nrow = ctx$n_x)
  Kx <- exp(-as.matrix(stats::dist(xs))^2 / scale^2)
  ts <- scale_unit(ctx$t)
  Kt <- exp(-outer(ts, ts, "-")^2 / scale^2)
  list(Kx = Kx, Kt = Kt)
}

# "other": y = eta(theta) + delta + e, delta ~ N(0, s tau^-1 K_l) a smooth
# discrepancy with variance s times the noise's, e ~ N(0, tau^-1 R_g).
# Evidence over runs x correlation grid points x scales x variance ratios.
#
# A smooth kernel has low numerical rank: K = B B' with B of r << n columns
# (pivoted Cholesky, stopped at LAPACK's rounding tolerance, so exact to
# rounding). Then, with P = R_g^-1 and B'PB = V L V', Woodbury gives, for
# every ratio s at once, r'(R_g + s K)^-1 r = Q - sum_i s z_i^2 / (1 + s l_i)
# with z = V'B'P r, and log|R_g + s K| = log|R_g| + sum_i log(1 + s l_i):
# one runs x r product per grid point instead of a dense n x n factor and
# solve per grid point, scale and ratio.
other_log_evidence <- function(ctx, base_terms, scales, ratios = 4^(1:4)) {
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
  keep <- if (any(smooth)) which(smooth) else which.max(scales)
  kernels <- kernels[keep]
  # without a noise pattern, P = R_x^-1 (x) Pt and K = Kx (x) Kt: the
  # products go factor by factor (kronecker_products())
  kron <- !ctx$is_dense && is.null(ctx$sd)
  factors <- if (kron) {
    lapply(scales[keep], function(sc) lapply(smooth_kernel_parts(ctx, sc), low_rank_factor))
  } else {
    lapply(kernels, function(K) low_rank_factor(sd2 * K[ctx$obs, ctx$obs, drop = FALSE]))
  }
  # per grid point and kernel, every ratio's sum_i s z_i^2 / (1 + s l_i)
  # (runs x ratios) and the eigenvalues l, for pairs in chunks of about 2^22
  # numbers (several pairs per pass over the runs, a bounded temporary)
  J <- nrow(base_terms$Y)
  pairs <- expand.grid(i = seq_along(factors), g = seq_along(ctx$points))
  per_chunk <- max(1L, floor(2^22 / (J * length(ratios))))
  chunks <- split(seq_len(nrow(pairs)), ceiling(seq_len(nrow(pairs)) / per_chunk))
  pieces <- unlist(lapply(chunks, function(ms) {
    drops <- if (kron) kronecker_products(ctx, base_terms$Y, factors, pairs[ms, ], ratios) else
      dense_products(ctx, base_terms$Y, factors, pairs[ms, ], ratios)
    vapply(seq_along(ms), function(j) {
      g <- pairs$g[ms[j]]
      l <- drops[[j]]$l
      # the log evidence summed over the ratios (as the ratios' columns of a
      # grid posterior, src/exact_posterior.cpp), up to the constant added below
      grid_posterior_cpp(pmax(base_terms$Q[, g] - drops[[j]]$drop_by, 0),
                         ctx$prior$shape + sum(ctx$n) / 2, ctx$prior$rate,
                         ctx$logdet[g] + colSums(log1p(outer(l, ratios))),
                         base_terms$log_prior_run,
                         rep(ctx$points[[g]]$log_prior, length(ratios)), FALSE,
                         griddy_threads())$log_norm
    }, numeric(1))
  }), use.names = FALSE)
  log_sum_exp(pieces) + log_evidence_constant(ctx$prior, ctx$n) -
    log(length(kernels) * length(ratios))
}

# The Woodbury pieces of other_log_evidence() under a noise pattern: per
# (kernel i, grid point g) of `pairs`, list(drop_by = runs x ratios, l).
dense_products <- function(ctx, Y, factors, pairs, ratios) {
  E <- (rep(ctx$y, each = nrow(Y)) - Y)[, ctx$obs, drop = FALSE]   # the observed points
  lapply(seq_len(nrow(pairs)), function(m) {
    B <- factors[[pairs$i[m]]]
    PB <- precision_times(ctx, ctx$points[[pairs$g[m]]], B)
    eig <- eigen(crossprod(B, PB), symmetric = TRUE)
    l <- pmax(eig$values, 0)
    list(drop_by = (E %*% (PB %*% eig$vectors))^2 %*% ratio_weights(l, ratios), l = l)
  })
}

# The Woodbury pieces of other_log_evidence() for K = Kx (x) Kt = (Bx Bx')
# (x) (Bt Bt') and P = R_x^-1 (x) Pt (no noise pattern): B'PB = (Bx'R_x^-1
# Bx) (x) (Bt'Pt Bt) has eigenvalues lx (x) lt and eigenvectors Vx (x) Vt,
# so z = (Vx (x) Vt)' B'P e = Mt' E_j Mx for each run's residual E_j = y -
# Y_j as an n_t x n_x matrix, Mt = Pt Bt Vt and Mx = R_x^-1 Bx Vx: per run
# n_t n_x rx + rx n_t rt products instead of n_x n_t rx rt (the same
# quantities as the full factor, to rounding). Z (entry (ix - 1) rt + it) is
# reduced at once to drop_by, runs x ratios: sum_i s z_i^2 / (1 + s l_i) for
# each ratio s. Every pair (kernel, grid point) in one pass over the runs'
# outputs, a block of runs at a time (other_drops_cpp(),
# src/other_products.cpp); the x step depends on the kernel and R_x^-1 only,
# so grid points that share R_x^-1 (all of them without rho_x) share it.
kronecker_products <- function(ctx, Y, factors, pairs, ratios) {
  x_steps <- list()
  step_of <- integer(nrow(pairs))
  for (m in seq_len(nrow(pairs))) {
    Rx_inv <- ctx$points[[pairs$g[m]]]$Rx_inv
    i <- pairs$i[m]
    hit <- Position(function(st) st$i == i && identical(st$Rx_inv, Rx_inv), x_steps)
    if (is.na(hit)) {
      x_steps[[length(x_steps) + 1L]] <- c(kronecker_x_step(Rx_inv, factors[[i]]$Kx), i = i)
      hit <- length(x_steps)
    }
    step_of[m] <- hit
  }
  x_count <- vapply(x_steps, function(st) ncol(st$Mx), integer(1))
  x_first <- c(0L, cumsum(x_count))[seq_along(x_steps)]
  terms <- lapply(seq_len(nrow(pairs)), function(m) {
    Pt <- ctx$points[[pairs$g[m]]]$Pt
    Bt <- factors[[pairs$i[m]]]$Kt
    PtBt <- ar1_precision_times(Pt, Bt)
    et <- eigen(crossprod(Bt, PtBt), symmetric = TRUE)
    l <- kronecker(x_steps[[step_of[m]]]$lx, pmax(et$values, 0))
    list(Mt = PtBt %*% et$vectors, W = ratio_weights(l, ratios), l = l)
  })
  drops <- other_drops_cpp(Y, ctx$y, do.call(cbind, lapply(x_steps, `[[`, "Mx")),
                           lapply(terms, `[[`, "Mt"), lapply(terms, `[[`, "W"),
                           x_first[step_of], x_count[step_of], griddy_threads())
  k <- length(ratios)
  lapply(seq_len(nrow(pairs)), function(m) {
    list(drop_by = drops[, (m - 1L) * k + seq_len(k), drop = FALSE], l = terms[[m]]$l)
  })
}

# s / (1 + s l_i): one column per ratio s, one row per eigenvalue l_i.
ratio_weights <- function(l, ratios) {
  vapply(ratios, function(s) s / (1 + s * l), numeric(length(l)))
}

# The x step of a kernel: Mx = R_x^-1 Bx Vx and lx, the eigenvalues of
# Bx'R_x^-1 Bx (Vx their eigenvectors).
kronecker_x_step <- function(Rx_inv, Bx) {
  RxBx <- Rx_inv %*% Bx
  ex <- eigen(crossprod(Bx, RxBx), symmetric = TRUE)
  list(Rx_inv = Rx_inv, Mx = RxBx %*% ex$vectors, lx = pmax(ex$values, 0))
}

# B with K = B B' to rounding (K positive semi-definite): the rows of the
# pivoted Cholesky factor up to its numerical rank.
low_rank_factor <- function(K) {
  U <- suppressWarnings(chol(K, pivot = TRUE))
  r <- attr(U, "rank")
  B <- matrix(0, nrow(K), r)
  B[attr(U, "pivot"), ] <- t(U[seq_len(r), , drop = FALSE])
  B
}

# P M for the columns of M (data vectors over the observed points), P the
# grid point's inverse noise correlation (as apply_precision(), all columns
# at once).
precision_times <- function(ctx, point, M) {
  if (ctx$is_dense) return(point$P %*% M)
  n_t <- ctx$n_t
  n_x <- ctx$n_x
  r <- ncol(M)
  Tm <- ar1_precision_times(point$Pt, matrix(M, n_t, n_x * r))   # Pt on every block
  if (identical(unname(point$Rx_inv), diag(n_x))) return(matrix(Tm, n_t * n_x, r))
  # then R_x^-1 over the settings of every column
  Tm <- matrix(aperm(array(Tm, c(n_t, n_x, r)), c(1, 3, 2)), n_t * r, n_x) %*% point$Rx_inv
  matrix(aperm(array(Tm, c(n_t, r, n_x)), c(1, 3, 2)), n_t * n_x, r)
}
