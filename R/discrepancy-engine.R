# The discrepancy in the engine's quadratic forms, through low-rank factors
# of its kernels (issue 36): what dense_factors() and plain_quad_forms()
# (engine.R) do for a setup with a discrepancy.
#
# A squared-exponential kernel over a grid is numerically of low rank: over
# 160 values of t its eigenvalues fall below 1e-15 of the largest after 10
# to 44 of them (length 1 to 0.1). So K_l = F_l F_l' with F_l of m_l << n
# columns, and with R^-1 = A A' (the noise's whitening, A'r the whitened
# residual z) and the eigen-decomposition F_l' R^-1 F_l = V diag(d) V'
# (m_l x m_l), Woodbury and the determinant lemma give
#   r' (R + lambda K_l)^-1 r = |z|^2 - sum_j lambda / (1 + lambda d_j) (v_j' F_l' R^-1 r)^2,
#   log|R + lambda K_l| = log|R| + sum_j log(1 + lambda d_j),
# the same algebra as the full rotation it replaces (discrepancy.md, section
# 3), in m_l dimensions instead of n. |z|^2 is the plain form (the AR(1) and
# Kronecker whitening in O(n) per run for complete data). The kernels of all
# length scales are written in one basis B (the kernels' factors are B C_l):
# per rho every run's B' R^-1 r is one product, runs x n x m_B, and each
# length scale then rotates those m_B numbers, not the n residuals.
#
# The factors: an axis kernel's eigenpairs above 1e-15 of its largest (the
# rest is rounding, which the full rotation clamped to 0 as well), the x and
# t factors combined by the Kronecker product; an orthogonal discrepancy's
# P F (P the projector off the sensitivities Q, so B gains Q's columns); a
# scaled one's F (I + F_o' F_o / c)^-1/2 (Gu and Wang's kernel, push-through
# identity: no decomposition per ratio beyond m x m). A kernel conditioned on
# knowledge (zero_at, flat_at) is decomposed whole, once per length scale.

# Eigenvalues below this fraction of the largest are rounding.
factor_tolerance <- 1e-15

# A factor F (columns sqrt(value) times vector) of the symmetric PSD matrix K,
# its eigenpairs above factor_tolerance of the largest.
psd_factor <- function(K) {
  e <- eigen((K + t(K)) / 2, symmetric = TRUE)
  keep <- e$values > factor_tolerance * max(e$values, 0)
  sweep(e$vectors[, keep, drop = FALSE], 2, sqrt(e$values[keep]), "*")
}

# The discrepancy kernels of discrepancy_kernels() as factors over every
# library output: list(basis = B (outputs x m_B), coef = one C_l (m_B x m_l)
# per row of `kernels`), so that K_l = (B C_l)(B C_l)'.
discrepancy_kernel_factors <- function(library, kernels) {
  d2 <- scaled_sq_distances(library)
  d2_x <- d2$x
  d2_t <- d2$t
  knowledge <- knowledge_observations(library, attr(kernels, "zero_at"),
                                      attr(kernels, "flat_at"))
  if (!is.null(knowledge)) return(whole_kernel_factors(library, kernels))
  axis <- function(d2, len) if (is.na(len)) d2 * 0 + 1 else exp(-d2 / len^2)
  # per axis, a basis of all its length scales' kernels (the eigenvectors
  # of their sum) and each length's factor in it
  axis_factors <- function(d2, lens) {
    lens <- unique(lens)
    Ks <- lapply(lens, function(l) axis(d2, l))
    total <- Reduce(`+`, lapply(Ks, function(K) K / max(abs(K))))
    e <- eigen((total + t(total)) / 2, symmetric = TRUE)
    B <- e$vectors[, e$values > factor_tolerance * max(e$values), drop = FALSE]
    list(lens = lens, basis = B, coef = lapply(Ks, function(K) crossprod(B, psd_factor(K))))
  }
  fx <- axis_factors(d2_x, kernels$length_x)
  ft <- axis_factors(d2_t, kernels$length_t)
  basis <- kronecker(fx$basis, ft$basis)
  coef <- lapply(seq_len(nrow(kernels)), function(k) {
    kronecker(fx$coef[[match(kernels$length_x[k], fx$lens)]],
              ft$coef[[match(kernels$length_t[k], ft$lens)]])
  })
  G <- attr(kernels, "sensitivity")
  if (!is.null(G) && ncol(G) > 0L) {
    # P F = F - Q (Q' F): B gains Q's columns, C_l the rows -Q' B C_l
    Q <- qr.Q(qr(G))
    QB <- crossprod(Q, basis)
    coef <- lapply(coef, function(C) rbind(C, -QB %*% C))
    basis <- cbind(basis, Q)
  }
  if (!is.null(kernels$ratio)) coef <- scaled_coefs(basis, coef, kernels)
  list(basis = basis, coef = coef)
}

# With knowledge the kernel is not a Kronecker product: each length scale's
# whole kernel (conditioned, projected, scaled: discrepancy_kernels()) is
# decomposed, and the basis holds all their factors side by side.
whole_kernel_factors <- function(library, kernels) {
  Fs <- lapply(discrepancy_kernels(library, kernels), psd_factor)
  m <- vapply(Fs, ncol, 1L)
  ends <- cumsum(m)
  coef <- lapply(seq_along(Fs), function(k) {
    C <- matrix(0, sum(m), m[k])
    C[cbind(ends[k] - m[k] + seq_len(m[k]), seq_len(m[k]))] <- 1
    C
  })
  list(basis = do.call(cbind, Fs), coef = coef)
}

# A scaled (S-GaSP) kernel in factor form: with F = B C over the outputs and
# F_o its observed rows, K_z = F (I + F_o' F_o / c)^-1 F' (scaled_kernel()),
# c = n / lambda_z, so C becomes C E diag((1 + e / c)^-1/2) for F_o' F_o =
# E diag(e) E'.
scaled_coefs <- function(basis, coef, kernels) {
  observed <- attr(kernels, "observed")
  n <- length(observed)
  Bo <- basis[observed, , drop = FALSE]
  BtB <- crossprod(Bo)
  lapply(seq_along(coef), function(k) {
    C <- coef[[k]]
    e <- eigen(crossprod(C, BtB %*% C), symmetric = TRUE)
    lambda_z <- scaled_lambda_z(kernels$ratio[k], n,
                                c(kernels$length_x[k], kernels$length_t[k]))
    C %*% sweep(e$vectors, 2, 1 / sqrt(1 + pmax(e$values, 0) * lambda_z / n), "*")
  })
}

# ---- the dense factors ----------------------------------------------------------

# dense_factors() for a setup with a discrepancy: per base grid point (rho)
# and noise group, the whitening A (A A' = R_kk^-1 over the group's observed,
# sd-scaled points), the whitened basis H = A' B_k and per kernel T_l =
# C_l V_l and d_l (the eigenpairs of C_l' H' H C_l); per grid point its base
# point `base`, kernel `kernel` (0 for lambda = 0) and ratio, and its
# log-determinant. `kron`: complete data in one group without sd, whose
# residuals whiten by the AR(1) and Kronecker shortcuts (whiten_rows()).
discrepancy_dense_factors <- function(setup, t, pattern, disc, factors) {
  obs <- which(pattern$observed)
  groups <- split(seq_along(obs), factor(pattern$group[obs], seq_along(pattern$labels)))
  names(groups) <- pattern$labels
  scale <- if (!is.null(pattern$sd_mean)) 1 / pattern$sd_mean[obs]
  log_sd <- if (is.null(pattern$sd_mean)) 0 else
    2 * sum(log(pattern$sd_mean[obs])) + pattern$log_sd_excess
  n_t <- length(t)
  n_x <- dim(setup$Rx_chol)[1]
  kron <- length(obs) == n_x * n_t && is.null(scale) && length(groups) == 1L
  basis <- factors$basis[obs, , drop = FALSE]
  if (!is.null(scale)) basis <- basis * scale
  G <- length(setup$logdet)
  A <- vector("list", G)
  H <- A
  rot <- A
  base_logdet <- numeric(G)
  for (g in seq_len(G)) {
    if (kron) {
      # the whitening itself is kept, not its n x n matrix (made on demand)
      point <- kron_whitening(setup, g)
      A[[g]] <- point
      H[[g]] <- list(t(whiten_rows(t(basis), point, n_x, n_t)))
      base_logdet[g] <- setup$logdet[g]
    } else {
      base <- noise_group_factors(setup, g, t, obs, groups)
      A[[g]] <- base$A
      H[[g]] <- Map(function(a, idx) crossprod(a, basis[idx, , drop = FALSE]), A[[g]], groups)
      base_logdet[g] <- base$logdet + log_sd
    }
    J <- lapply(H[[g]], crossprod)
    rot[[g]] <- lapply(factors$coef, function(C) lapply(J, function(Jk) {
      e <- eigen(crossprod(C, Jk %*% C), symmetric = TRUE)
      list(T = C %*% e$vectors, d = pmax(e$values, 0))
    }))
  }
  D <- nrow(disc)
  grid <- data.frame(base = rep(seq_len(G), D), kernel = rep(disc$kernel, each = G),
                     ratio = rep(disc$ratio, each = G))
  logdet <- base_logdet[grid$base]
  for (j in which(grid$ratio > 0)) {
    d <- unlist(lapply(rot[[grid$base[j]]][[grid$kernel[j]]], `[[`, "d"))
    logdet[j] <- logdet[j] + sum(log1p(grid$ratio[j] * d))
  }
  list(obs = obs, scale = scale, groups = groups, kron = kron, A = A, H = H, rot = rot,
       grid = grid, logdet = logdet, lowrank = TRUE, basis_all = factors$basis)
}

# What whiten_rows() needs of base grid point g of a Kronecker setup.
kron_whitening <- function(setup, g) {
  n_x <- dim(setup$Rx_chol)[1]
  list(Rx_chol = matrix(setup$Rx_chol[, , setup$gx[g]], n_x, n_x),
       phi = setup$phi[, setup$gt[g]], n_x = n_x, n_t = length(setup$phi[, 1]) + 1L)
}

# The whitening of base grid point g as matrices, one per noise group.
base_factors <- function(dense, g) {
  if (!dense$kron) return(dense$A[[g]])
  point <- dense$A[[g]]
  stats::setNames(list(whiten_rows(diag(point$n_x * point$n_t), point, point$n_x, point$n_t)),
                  names(dense$groups))
}

# The whitening A_k = U_k^-1 of each noise group's observed block of R_g at
# base grid point g (U_k its upper Cholesky factor), and log|R| over the
# groups; a block numerically singular is an error (as in dense_factors()).
noise_group_factors <- function(setup, g, t, obs, groups) {
  U <- observed_noise_cholesky(setup, g, t, obs, groups)
  list(A = lapply(U, function(u) backsolve(u, diag(nrow(u)))),
       logdet = sum(vapply(U, function(u) 2 * sum(log(diag(u))), 0)))
}

# The factors A_k of grid point j (A A' = (R + lambda K)^-1 per group): with
# G = H T (G'G = diag(d)), A = A_R - (A_R G) diag(c) G', c_j = (1 - (1 +
# lambda d_j)^-1/2) / d_j, since I - G diag(lambda / (1 + lambda d)) G' is the
# square of I - G diag(c) G'.
discrepancy_point_factors <- function(dense, j) {
  at <- dense$grid[j, ]
  A <- base_factors(dense, at$base)
  if (at$ratio == 0) return(A)
  out <- lapply(seq_along(A), function(k) {
    r <- dense$rot[[at$base]][[at$kernel]][[k]]
    Gk <- dense$H[[at$base]][[k]] %*% r$T
    s <- sqrt(1 + at$ratio * r$d)
    cc <- at$ratio / (s * (s + 1))
    A[[k]] - (A[[k]] %*% Gk) %*% (cc * t(Gk))
  })
  stats::setNames(out, names(A))
}

# plain_quad_forms() for a setup with a discrepancy (see the top of this
# file): per base grid point, the whitened residuals' |z|^2 and their
# coordinates U = Z H in the basis; then the rotations U T of all kernels in
# one product, and every ratio's weights. The products run on the tiled
# kernels (tiled_matmul_cpp()).
discrepancy_quad_forms <- function(Y, y_field, setup, threads = griddy_threads()) {
  dense <- setup$dense
  grid <- dense$grid
  n_x <- dim(setup$Rx_chol)[1]
  product <- function(X, B) tiled_matmul_cpp(X, B, threads)
  C <- matrix(0, nrow(Y), nrow(grid))
  resid <- matrix(y_field, nrow(Y), length(y_field), byrow = TRUE) - Y
  blocks <- if (!dense$kron) group_columns(resid, dense)
  for (g in seq_along(dense$A)) {
    Z <- if (dense$kron) {
      list(whiten_rows(resid, dense$A[[g]], n_x, ncol(resid) %/% n_x))
    } else {
      Map(product, blocks, dense$A[[g]])
    }
    here <- which(grid$base == g)
    used <- unique(grid$kernel[here][grid$ratio[here] > 0])
    Ck <- lapply(seq_along(Z), function(k) {
      C0 <- rowSums(Z[[k]]^2) + setup$pure_ss[k]
      out <- matrix(C0, nrow(Y), length(here))
      if (length(used) == 0L) return(out)
      rots <- lapply(dense$rot[[g]][used], `[[`, k)
      Z2 <- product(product(Z[[k]], dense$H[[g]][[k]]), do.call(cbind, lapply(rots, `[[`, "T")))^2
      ends <- cumsum(vapply(rots, function(r) length(r$d), 1L))
      for (i in seq_along(used)) {
        at <- which(grid$kernel[here] == used[i] & grid$ratio[here] > 0)
        lambda <- grid$ratio[here][at]
        d <- rots[[i]]$d
        weights <- outer(d, lambda, function(d, lam) lam / (1 + lam * d))
        cols <- seq_len(length(d)) + ends[i] - length(d)
        # a quadratic form is >= 0; the difference can round below
        out[, at] <- pmax(out[, at, drop = FALSE] - Z2[, cols, drop = FALSE] %*% weights, 0)
      }
      out
    })
    C[, here] <- if (length(Ck) == 1L) Ck[[1]] else {
      vapply(seq_along(here), function(j) {
        fold_groups(vapply(Ck, function(M) M[, j], numeric(nrow(Y))), setup)
      }, numeric(nrow(Y)))
    }
  }
  if (!all(is.finite(C))) {
    griddy_abort("quad_forms: a misfit is not finite: the outputs hold NA, NaN or Inf, or ",
                 "overflow double precision.", class = "numeric")
  }
  C
}

# group_quad_forms() at grid point g of a setup with a discrepancy: each
# group's |z|^2 less the ratio's weighted squares of the rotated
# coordinates (as discrepancy_quad_forms(), for one grid point), with the
# group's pure error.
discrepancy_group_forms <- function(resid, setup, g) {
  dense <- setup$dense
  at <- dense$grid[g, ]
  Z <- if (dense$kron) {
    w <- dense$A[[at$base]]
    list(whiten_rows(resid, w, w$n_x, w$n_t))
  } else {
    Map(`%*%`, group_columns(resid, dense), dense$A[[at$base]])
  }
  Ck <- vapply(seq_along(Z), function(k) {
    C0 <- rowSums(Z[[k]]^2) + setup$pure_ss[k]
    if (at$ratio == 0) return(C0)
    r <- dense$rot[[at$base]][[at$kernel]][[k]]
    u <- Z[[k]] %*% (dense$H[[at$base]][[k]] %*% r$T)
    pmax(C0 - drop(u^2 %*% (at$ratio / (1 + at$ratio * r$d))), 0)
  }, numeric(nrow(resid)))
  matrix(Ck, nrow(resid))
}
