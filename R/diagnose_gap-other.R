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
  kron <- !ctx$dense && is.null(ctx$sd)
  factors <- if (kron) {
    lapply(scales[keep], function(sc) lapply(smooth_kernel_parts(ctx, sc), low_rank_factor))
  } else {
    lapply(kernels, function(K) low_rank_factor(sd2 * K[ctx$obs, ctx$obs, drop = FALSE]))
  }
  E <- if (length(ctx$obs) == ncol(base_terms$E)) base_terms$E else
    base_terms$E[, ctx$obs, drop = FALSE]
  # the x step of kronecker_products() depends on the kernel and R_x^-1 only:
  # kept for the grid points that share R_x^-1 (all of them without rho_x)
  x_steps <- vector("list", length(factors))
  x_step <- function(i, point) {
    last <- x_steps[[i]]
    if (is.null(last) || !identical(last$Rx_inv, point$Rx_inv)) {
      last <- kronecker_x_step(point$Rx_inv, factors[[i]]$Kx, E, ctx$n_t)
      x_steps[[i]] <<- last
    }
    last
  }
  pieces <- unlist(lapply(seq_along(ctx$points), function(g) {
    point <- ctx$points[[g]]
    unlist(lapply(seq_along(factors), function(i) {
      B <- factors[[i]]
      # every ratio's sum_i s z_i^2 / (1 + s l_i) from one product (runs x ratios)
      if (kron) {
        kp <- kronecker_products(point, x_step(i, point), B$Kt, nrow(E), ctx$n_t, ratios)
        l <- kp$l
        drop_by <- kp$drop_by
      } else {
        PB <- precision_times(ctx, point, B)
        eig <- eigen(crossprod(B, PB), symmetric = TRUE)
        l <- pmax(eig$values, 0)
        drop_by <- (E %*% (PB %*% eig$vectors))^2 %*% ratio_weights(l, ratios)
      }
      vapply(seq_along(ratios), function(k) {
        s <- ratios[k]
        Q <- base_terms$Q[, g] - drop_by[, k]
        log_sum_exp(collapsed_log_joint(matrix(pmax(Q, 0)), ctx$n,
                                        ctx$logdet[g] + sum(log1p(s * l)), ctx$prior,
                                        base_terms$log_prior_run, point$log_prior))
      }, numeric(1))
    }))
  }))
  log_sum_exp(pieces) - log(length(kernels) * length(ratios))
}

# The Woodbury pieces of other_log_evidence() for K = Kx (x) Kt = (Bx Bx')
# (x) (Bt Bt') and P = R_x^-1 (x) Pt (no noise pattern): B'PB = (Bx'R_x^-1
# Bx) (x) (Bt'Pt Bt) has eigenvalues lx (x) lt and eigenvectors Vx (x) Vt,
# so z = (Vx (x) Vt)' B'P e = Mt' E_j Mx for each run's residual E_j as an
# n_t x n_x matrix, Mt = Pt Bt Vt and Mx = R_x^-1 Bx Vx: per run n_t n_x rx
# (the x step, kronecker_x_step(), once per kernel) + rx n_t rt products
# instead of n_x n_t rx rt (the same quantities as the full factor, to
# rounding). Z (column (ix - 1) rt + it) is reduced at once to drop_by, runs x
# ratios: sum_i s z_i^2 / (1 + s l_i) for each ratio s.
kronecker_products <- function(point, xs, Bt, J, n_t, ratios) {
  PtBt <- ar1_precision_times(point$Pt, Bt)
  et <- eigen(crossprod(Bt, PtBt), symmetric = TRUE)
  Mt <- PtBt %*% et$vectors
  rx <- length(xs$Ex)
  l <- kronecker(xs$lx, pmax(et$values, 0))
  weights <- ratio_weights(l, ratios)
  rt <- ncol(Mt)
  # Z's columns of x direction ix, squared and weighted, summed block by block
  # (no runs x (rx rt) matrix)
  drop_by <- matrix(0, J, length(ratios))
  for (ix in seq_len(rx)) {
    Zx <- xs$Ex[[ix]] %*% Mt
    drop_by <- drop_by + (Zx * Zx) %*% weights[(ix - 1L) * rt + seq_len(rt), , drop = FALSE]
  }
  list(drop_by = drop_by, l = l)
}

# s / (1 + s l_i): one column per ratio s, one row per eigenvalue l_i.
ratio_weights <- function(l, ratios) {
  vapply(ratios, function(s) s / (1 + s * l), numeric(length(l)))
}

# The x step: Ex = the runs' residuals (rows of n_t, one column per x
# setting) times Mx = R_x^-1 Bx Vx, as one runs x n_t matrix per x direction,
# and lx the eigenvalues of Bx'R_x^-1 Bx.
kronecker_x_step <- function(Rx_inv, Bx, E, n_t) {
  RxBx <- Rx_inv %*% Bx
  ex <- eigen(crossprod(Bx, RxBx), symmetric = TRUE)
  J <- nrow(E)
  Ex <- matrix(E, J * n_t, nrow(Bx)) %*% (RxBx %*% ex$vectors)
  list(Rx_inv = Rx_inv, Ex = lapply(seq_len(ncol(Ex)), function(ix) matrix(Ex[, ix], J, n_t)),
       lx = pmax(ex$values, 0))
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
  if (ctx$dense) return(point$P %*% M)
  n_t <- ctx$n_t
  n_x <- ctx$n_x
  r <- ncol(M)
  Tm <- ar1_precision_times(point$Pt, matrix(M, n_t, n_x * r))   # Pt on every block
  if (identical(unname(point$Rx_inv), diag(n_x))) return(matrix(Tm, n_t * n_x, r))
  # then R_x^-1 over the settings of every column
  Tm <- matrix(aperm(array(Tm, c(n_t, n_x, r)), c(1, 3, 2)), n_t * r, n_x) %*% point$Rx_inv
  matrix(aperm(array(Tm, c(n_t, r, n_x)), c(1, 3, 2)), n_t * n_x, r)
}
