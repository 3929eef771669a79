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
  # the axes' factors, while every kernel is their Kronecker product (not
  # after a projection or a scaling): the forms then work per axis
  axes <- list(x = fx, t = ft, kx = match(kernels$length_x, fx$lens),
               kt = match(kernels$length_t, ft$lens))
  if (!is.null(G) && ncol(G) > 0L) {
    axes <- NULL
    # P F = F - Q (Q' F): B gains Q's columns, C_l the rows -Q' B C_l
    Q <- qr.Q(qr(G))
    QB <- crossprod(Q, basis)
    coef <- lapply(coef, function(C) rbind(C, -QB %*% C))
    basis <- cbind(basis, Q)
  }
  if (!is.null(kernels$ratio)) {
    coef <- scaled_coefs(basis, coef, kernels)
    axes <- NULL
  }
  # the basis's leading columns stay kronecker(B_x, B_t) whatever follows
  list(basis = basis, coef = coef, axes = axes,
       axis_basis = list(x = fx$basis, t = ft$basis))
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
  layout <- observed_layout(pattern)
  obs <- layout$obs
  groups <- layout$groups
  scale <- layout$scale
  log_sd <- layout$log_sd
  n_t <- length(t)
  n_x <- dim(setup$Rx_chol)[1]
  kron <- length(obs) == n_x * n_t && is.null(scale) && length(groups) == 1L
  basis <- factors$basis[obs, , drop = FALSE]
  if (!is.null(scale)) basis <- basis * scale
  G <- length(setup$logdet)
  A <- vector("list", G)
  H <- A
  rot <- A
  axis_rot <- if (kron && !is.null(factors$axes)) A
  axis_basis <- if (kron && is.null(axis_rot) && !is.null(factors$axis_basis)) A
  base_logdet <- numeric(G)
  product <- function(X, B) tiled_matmul_cpp(X, B, griddy_threads())
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
    if (kron && !is.null(factors$axes)) {
      ax <- kron_axis_rotations(A[[g]], factors$axes)
      axis_rot[[g]] <- ax
      rot[[g]] <- lapply(seq_along(factors$coef), function(l) {
        x <- ax$x[[factors$axes$kx[l]]]
        t <- ax$t[[factors$axes$kt[l]]]
        list(list(T = kronecker(x$T, t$T), d = as.vector(kronecker(x$d, t$d))))
      })
      next
    }
    J <- if (!is.null(axis_basis)) {
      axis_basis[[g]] <- whitened_axes(A[[g]], factors$axis_basis)
      list(kron_gram(H[[g]][[1]], axis_basis[[g]], product))
    } else {
      lapply(H[[g]], crossprod)
    }
    rot[[g]] <- lapply(factors$coef, function(C) {
      Ct <- t(C)
      lapply(J, function(Jk) {
        e <- eigen(product(Ct, product(Jk, C)), symmetric = TRUE)
        list(T = product(C, e$vectors), d = pmax(e$values, 0))
      })
    })
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
       axes = if (!is.null(axis_rot)) factors$axes[c("kx", "kt")], axis_rot = axis_rot,
       axis_basis = axis_basis,
       grid = grid, logdet = logdet, lowrank = TRUE, basis_all = factors$basis)
}

# Complete data and Kronecker kernels: R^-1 = (A_x A_x') (x) (W_t' W_t) and
# K_l = (B_x C_x)(B_x C_x)' (x) (B_t C_t)(B_t C_t)', so the whitened basis
# is H_x (x) H_t and C_l' H'H C_l = (C_x' H_x'H_x C_x) (x) (C_t' H_t'H_t C_t):
# its eigenpairs are the products of the axes' (T_l = T_x (x) T_t, d_l =
# d_x (x) d_t). Per axis length: T, d and G = H T (the whitened factor's
# columns, which the forms multiply the residuals by).
kron_axis_rotations <- function(point, axes) {
  H <- whitened_axes(point, list(x = axes$x$basis, t = axes$t$basis))
  H_x <- H$x
  H_t <- H$t
  rotate <- function(H, C) {
    e <- eigen(crossprod(H %*% C), symmetric = TRUE)
    rotation <- C %*% e$vectors
    list(T = rotation, d = pmax(e$values, 0), G = H %*% rotation)
  }
  list(x = lapply(axes$x$coef, function(C) rotate(H_x, C)),
       t = lapply(axes$t$coef, function(C) rotate(H_t, C)))
}

# H'H for the whitened basis H of a Kronecker grid point, whose leading
# columns are kronecker(H_x, H_t) (`ax`, whitened_axes()): that block's Gram
# matrix is kronecker(H_x'H_x, H_t'H_t), its products with the other
# columns R one kron_product(), so only R'R is a product over the n
# outputs (the rest per axis, n_x + n_t long).
kron_gram <- function(H, ax, product) {
  m <- ncol(ax$x) * ncol(ax$t)
  J <- kronecker(crossprod(ax$x), crossprod(ax$t))
  if (m == ncol(H)) return(J)
  R <- H[, -seq_len(m), drop = FALSE]
  JR <- t(kron_product(t(R), ax$x, ax$t, product))
  rbind(cbind(J, JR), cbind(t(JR), crossprod(R)))
}

# The axes' bases whitened at a Kronecker grid point: kronecker(x, t) is the
# whitened kronecker(B_x, B_t).
whitened_axes <- function(point, basis) {
  A_x <- backsolve(point$Rx_chol, diag(point$n_x))
  H_t <- basis$t
  if (any(point$phi != 0)) H_t <- t(ar1_whiten_rows_cpp(t(H_t), point$phi, 1L))
  list(x = crossprod(A_x, basis$x), t = H_t)
}

# Z (runs x n_x n_t) times kronecker(G_x, G_t): one product over every
# (run, setting) by G_t, then one over the settings by G_x.
kron_product <- function(Z, G_x, G_t, product) {
  runs <- nrow(Z)
  n_x <- nrow(G_x)
  n_t <- nrow(G_t)
  W <- product(setting_rows(Z, runs, n_x, n_t), G_t)
  W <- block_transpose_cpp(W, runs, n_x, ncol(G_t), 0L)
  matrix(product(W, G_x), runs, ncol(G_t) * ncol(G_x))
}

# Z (runs x n_x n_t, library order) with a row per (run, setting), run
# fastest, and a column per t: the rows a product over t works on.
setting_rows <- function(Z, runs, n_x, n_t) block_transpose_cpp(Z, runs, n_t, n_x, 0L)

# Z H for the whitened basis H of base point g: its Kronecker columns per
# axis (kron_product()), the rest (the sensitivities') as one product.
whitened_coordinates <- function(Z, dense, g, H, product) {
  ax <- dense$axis_basis[[g]]
  if (is.null(ax)) return(product(Z, H))
  m <- ncol(ax$x) * ncol(ax$t)
  ZH <- kron_product(Z, ax$x, ax$t, product)
  if (m == ncol(H)) return(ZH)
  cbind(ZH, product(Z, H[, -seq_len(m), drop = FALSE]))
}

# The coordinates G_l'z of whitened residuals Z (runs x n_x n_t, complete
# data) for kernels `used`, side by side in the order of their rotations
# (kronecker(T_x, T_t)): per t length one product over every (run, setting),
# then per kernel one over the settings, runs x n_x (m_t + m_x m_t) numbers
# per kernel instead of runs x n m_B.
kron_coordinates <- function(Z, dense, g, used, product) {
  ax <- dense$axis_rot[[g]]
  runs <- nrow(Z)
  n_x <- nrow(ax$x[[1]]$G)
  n_t <- ncol(Z) %/% n_x
  kt <- dense$axes$kt[used]
  kx <- dense$axes$kx[used]
  t_used <- unique(kt)
  Gt <- do.call(cbind, lapply(ax$t[t_used], `[[`, "G"))
  m_t <- vapply(ax$t[t_used], function(a) ncol(a$G), 1L)
  start <- cumsum(m_t) - m_t
  W <- product(setting_rows(Z, runs, n_x, n_t), Gt)
  # per t length, rows (run, t coordinate) and a column per setting
  Wt <- lapply(seq_along(t_used), function(b) {
    block_transpose_cpp(W, runs, n_x, m_t[b], start[b])
  })
  do.call(cbind, lapply(seq_along(used), function(i) {
    b <- match(kt[i], t_used)
    Gx <- ax$x[[kx[i]]]$G
    matrix(product(Wt[[b]], Gx), runs, m_t[b] * ncol(Gx))
  }))
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
# file): discrepancy_forms() at every grid point.
discrepancy_quad_forms <- function(Y, y_field, setup, threads = griddy_threads()) {
  resid <- matrix(y_field, nrow(Y), length(y_field), byrow = TRUE) - Y
  C <- discrepancy_forms(resid, setup, seq_len(nrow(setup$dense$grid)), threads = threads)$C
  if (!all(is.finite(C))) {
    griddy_abort("quad_forms: a misfit is not finite: the outputs hold NA, NaN or Inf, or ",
                 "overflow double precision.", class = "numeric")
  }
  C
}

# group_quad_forms() at grid point g of a setup with a discrepancy: each
# group's form, with the group's pure error (runs x groups).
discrepancy_group_forms <- function(resid, setup, g) {
  discrepancy_forms(resid, setup, g, fold = FALSE)$C
}

# emulated_quad_forms() (emulation.R) for a setup with a discrepancy: runs
# predicted with error model `err` and relative variances `kappa`, at every
# grid point; list(C, logdet = the error's extra log-determinants).
discrepancy_emulated_forms <- function(y, y_field, setup, err, kappa) {
  resid <- matrix(y_field, nrow(y), length(y_field), byrow = TRUE) - y
  discrepancy_forms(resid, setup, seq_len(nrow(setup$dense$grid)), err, kappa)
}

# emulated_group_forms() for a setup with a discrepancy, at grid point g:
# list(C = runs x noise groups, logdet).
discrepancy_emulated_group_forms <- function(y, y_field, setup, err, kappa, g) {
  resid <- matrix(y_field, nrow(y), length(y_field), byrow = TRUE) - y
  discrepancy_forms(resid, setup, g, err, kappa, fold = FALSE)
}

# The quadratic forms of residual rows `resid` (library order) at grid
# points `points` of a setup with a discrepancy (see the top of this file):
# per base grid point, each group's whitened residuals z = A'r, their |z|^2
# and their coordinates in the basis, rotated by every kernel used in one
# product; every ratio then weighs the squared coordinates. Returns
# list(C = runs x points, folded over the noise groups, or runs x groups
# for one point with `fold = FALSE`; logdet).
#
# With an emulation error (`err`, emulation.R: V = U diag(lambda) U', on
# each group's noise variance s2_k) a run's covariance gains kappa_i F F',
# F = U diag(sqrt(lambda / s2_k)) over the group's sd-scaled points. With S
# the grid point's covariance (R + lambda K), b = F' S^-1 r and F' S^-1 F =
# Q diag(gamma) Q', the form loses sum_m kappa_i (b'Q)_m^2 / (1 + kappa_i
# gamma_m) and `logdet` (the error's extra log-determinant, as
# emulated_group_forms()'s) is sum_m log(1 + kappa_i gamma_m). Both come
# from the whitened factor A'F in the same coordinates: S^-1 = A (I - G
# diag(w) G') A' with G = H T and w = lambda / (1 + lambda d), so, per ratio,
# only m x m matrices and one product of every run's coordinates, no n x n
# work. `logdet` is NULL without an error.
discrepancy_forms <- function(resid, setup, points, err = NULL, kappa = NULL, fold = TRUE,
                              threads = griddy_threads()) {
  dense <- setup$dense
  grid <- dense$grid
  product <- function(X, B) tiled_matmul_cpp(X, B, threads)
  n_groups <- length(dense$groups)
  n_x <- dim(setup$Rx_chol)[1]
  s2 <- if (!is.null(err)) rep_len(err$noise_var, n_groups)
  whiten <- function(M, g) {
    if (dense$kron) {
      w <- dense$A[[g]]
      list(whiten_rows(M, w, n_x, ncol(M) %/% n_x))
    } else {
      Map(product, group_columns(M, dense), dense$A[[g]])
    }
  }
  C <- matrix(0, nrow(resid), if (fold) length(points) else n_groups)
  extra <- if (!is.null(err)) matrix(0, nrow(resid), if (fold) length(points) else 1L)
  for (g in unique(grid$base[points])) {
    here <- which(grid$base[points] == g)
    Z <- whiten(resid, g)
    WF <- if (!is.null(err)) {
      Map(function(W, s) W * sqrt(err$lambda / s), whiten(t(err$U), g), s2)
    }
    Ck <- lapply(seq_len(n_groups), function(k) {
      discrepancy_group_block(Z[[k]], WF[[k]], dense, g, k, points[here], setup$pure_ss[k],
                              kappa, product)
    })
    if (!fold) {
      C[] <- vapply(Ck, `[[`, numeric(nrow(resid)), "C")
      if (!is.null(err)) extra[] <- Reduce(`+`, lapply(Ck, `[[`, "logdet"))
      next
    }
    C[, here] <- if (n_groups == 1L) Ck[[1]]$C else {
      vapply(seq_along(here), function(j) {
        fold_groups(vapply(Ck, function(f) f$C[, j], numeric(nrow(resid))), setup)
      }, numeric(nrow(resid)))
    }
    if (!is.null(err)) extra[, here] <- Reduce(`+`, lapply(Ck, `[[`, "logdet"))
  }
  list(C = C, logdet = if (!is.null(err)) drop_one(extra, fold))
}

# A run's extra log-determinant at one grid point is a vector.
drop_one <- function(extra, fold) if (fold) extra else extra[, 1]

# Noise group k's forms at grid points `at` (rows of dense$grid, all on base
# point g): Z its whitened residuals (runs x points), WF its whitened error
# factor A'F, transposed (rank x points; NULL without an error), `pure_ss`
# its replicates' pure error. list(C, logdet), runs x points (see
# discrepancy_forms()).
discrepancy_group_block <- function(Z, WF, dense, g, k, at, pure_ss, kappa, product) {
  grid <- dense$grid[at, , drop = FALSE]
  out <- matrix(rowSums(Z^2) + pure_ss, nrow(Z), length(at))
  error <- !is.null(WF)
  extra <- if (error) matrix(0, nrow(Z), length(at))
  on <- grid$ratio > 0
  if (error) {
    zF <- product(Z, t(WF))   # F' R^-1 r
    FF <- tcrossprod(WF)      # F' R^-1 F
    # ratio 0: the noise and the error alone
    if (any(!on)) {
      eg <- eigen(FF, symmetric = TRUE)
      gamma <- pmax(eg$values, 0)
      loss <- rowSums(product(zF, eg$vectors)^2 * error_shrink(kappa, gamma))
      out[, !on] <- out[, !on] - loss
      extra[, !on] <- error_logdet(kappa, gamma)
    }
  }
  used <- unique(grid$kernel[on])
  if (length(used) == 0L) return(list(C = out, logdet = extra))
  rots <- lapply(dense$rot[[g]][used], `[[`, k)
  H <- dense$H[[g]][[k]]
  T_all <- do.call(cbind, lapply(rots, `[[`, "T"))
  P <- if (!is.null(dense$axis_rot)) {
    kron_coordinates(Z, dense, g, used, product)
  } else {
    product(whitened_coordinates(Z, dense, g, H, product), T_all)   # G'z, every kernel's
  }
  PF <- if (error) (WF %*% H) %*% T_all       # (G'A'F)'
  ends <- cumsum(vapply(rots, function(r) length(r$d), 1L))
  for (i in seq_along(used)) {
    cols <- seq_len(length(rots[[i]]$d)) + ends[i] - length(rots[[i]]$d)
    pts <- which(on & grid$kernel == used[i])
    lambda <- grid$ratio[pts]
    weights <- outer(rots[[i]]$d, lambda, function(d, lam) lam / (1 + lam * d))
    Pi <- P[, cols, drop = FALSE]
    # a quadratic form is >= 0; the difference can round below (pmax()'s
    # values, without its cost per call)
    v <- out[, pts, drop = FALSE] - product(Pi^2, weights)
    v[v < 0] <- 0
    out[, pts] <- v
    if (!error) next
    # per ratio, F' S^-1 F = FF - PF diag(w) PF' = Q diag(gamma) Q', and the
    # runs' (b'Q) = [zF, P] [Q; -diag(w) PF' Q], all ratios in one product
    PFi <- PF[, cols, drop = FALSE]
    pieces <- lapply(seq_along(lambda), function(m) {
      wPF <- weights[, m] * t(PFi)
      eg <- eigen(FF - PFi %*% wPF, symmetric = TRUE)
      list(phi = rbind(eg$vectors, -wPF %*% eg$vectors), gamma = pmax(eg$values, 0))
    })
    E <- product(cbind(zF, Pi), do.call(cbind, lapply(pieces, `[[`, "phi")))
    # every ratio's loss and log-determinant at once (E's columns are the
    # ratios' directions side by side; a loop over ratios cost more in R
    # than its arithmetic)
    kg <- outer(kappa, unlist(lapply(pieces, `[[`, "gamma")))
    by_ratio <- outer(rep(seq_along(pts), each = ncol(zF)), seq_along(pts), "==") * 1
    out[, pts] <- out[, pts, drop = FALSE] - (E^2 * (kappa / (1 + kg))) %*% by_ratio
    extra[, pts] <- log1p(kg) %*% by_ratio
  }
  list(C = out, logdet = extra)
}
