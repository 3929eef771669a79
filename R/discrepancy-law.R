# The conditional law of the discrepancy delta given a library run i, a grid
# point g (ratio lambda, length scales) and the noise precisions tau: the
# one place that says it. discrepancy_posterior() (and through it summary(),
# predict() and calibrate()'s gap warning) and diagnose_gap() without
# candidates (discrepancy_where()) both read it.
#
# Within each noise group (delta and the noise are independent between
# groups), with o the group's observed outputs, S their sd, r_i = y - g_i over
# o and Sigma = S R_g S + lambda K_oo (so Cov(y) = tau^-1 Sigma, data units),
# at the group's outputs c (observed or not):
#   delta_c | y ~ N(lambda K_co Sigma^-1 r_i,
#                   tau^-1 (lambda K_cc - lambda K_co Sigma^-1 lambda K_oc)).
# The engine's factor A (grid_point()$dense$A, A A' = (R + lambda K~)^-1 on
# sd-scaled data, K~ = S^-1 K S^-1) gives Sigma^-1 = S^-1 A A' S^-1, so with
# B = lambda K_co S^-1 A the mean is B z_i, z_i = A' S^-1 r_i the whitened
# residual of whiten_groups(), and the covariance is tau^-1 P with
# P = lambda K_cc - B B'. The mean does not depend on tau; lambda = 0 gives
# delta = 0 (see ../shared/notes/discrepancy.md, section 5).

# delta's law at grid point g of `setup`: the grid point and, per noise
# group k, its outputs `cells` (library order: all of the group's outputs,
# or with `observed_only` its observed ones), B and the prior covariance
# `prior` = lambda K_cc. NULL at lambda = 0. `kernels` is
# discrepancy_kernels() of the setup's library (computed once by the caller),
# or NULL for the library's own outputs of a setup with low-rank factors.
delta_law <- function(setup, g, kernels, observed_only = FALSE) {
  d <- setup$discrepancy[setup$gd[g], ]
  if (d$ratio == 0) return(NULL)
  # predict() at new settings extends the kernels beyond the library's
  # outputs, which the factors do not reach: the full law there
  if (isTRUE(setup$dense$lowrank) &&
      (is.null(kernels) || NROW(kernels[[d$kernel]]) == nrow(setup$dense$basis_all))) {
    return(lowrank_delta_law(setup, g, observed_only))
  }
  point <- grid_point(setup, g)
  layout <- point$dense
  K <- kernels[[d$kernel]]
  groups <- lapply(seq_along(layout$groups), function(k) {
    idx <- layout$groups[[k]]
    obs <- layout$obs[idx]
    cells <- if (observed_only) obs else which(setup$pattern$group == k)
    scale <- if (is.null(layout$scale)) 1 else layout$scale[idx]
    list(cells = cells,
         B = d$ratio * K[cells, obs, drop = FALSE] %*% (scale * layout$A[[k]]),
         prior = d$ratio * K[cells, cells, drop = FALSE])
  })
  list(point = point, groups = groups)
}

# The conditional means of delta under `law` (a delta_law()) for the
# residuals `resid` = y - g_i (one row per run, one column per library
# output): one row per run, one column per library output (0 at outputs the
# law leaves out).
delta_means <- function(law, resid) {
  z <- if (is.null(law$whiten)) whiten_groups(resid, law$point) else law$whiten(resid)
  m <- matrix(0, nrow(resid), ncol(resid))
  for (k in seq_along(law$groups)) {
    grp <- law$groups[[k]]
    m[, grp$cells] <- if (is.null(grp$L)) z[[k]] %*% t(grp$B) else {
      # B = L diag(p) (H T)' (lowrank_delta_law()), applied in that order
      sweep(z[[k]] %*% grp$HT, 2, grp$p, "*") %*% t(grp$L)
    }
  }
  m
}

# The conditional covariance of delta per unit tau^-1 over a group of a
# delta_law(): P = lambda K_cc - B B', symmetric (P is often numerically
# singular: smooth kernels, and zero where the data pin delta).
delta_cov <- function(grp) {
  if (!is.null(grp$L)) return(tcrossprod(sweep(grp$L, 2, sqrt(grp$p), "*")))
  P <- grp$prior - tcrossprod(grp$B)
  (P + t(P)) / 2
}

# Its diagonal, without forming P, and never below 0.
delta_cov_diag <- function(grp) {
  if (!is.null(grp$L)) return(drop(grp$L^2 %*% grp$p))
  pmax(diag(grp$prior) - rowSums(grp$B^2), 0)
}

# delta_law() of a setup whose discrepancy enters through low-rank factors
# (discrepancy-engine.R): with K = F F' (F = B C over the outputs, sd-scaled
# over the observed ones), M = F' R^-1 F = V diag(d) V' and u = F' R^-1 r =
# V' T' H' z, the mean is lambda F_c V diag(1 / (1 + lambda d)) V' u, so B =
# lambda L diag(1 / (1 + lambda d)) (H T)' with L = F_c V = B_c T; and the
# covariance lambda K_cc - lambda^2 K_co Sigma^-1 K_oc is L diag(p) L', p =
# lambda / (1 + lambda d): `L` and `p` stand for it (delta_cov()), exact
# where K_cc = F_c F_c' (to the factors' truncation, 1e-15 of the largest
# eigenvalue).
lowrank_delta_law <- function(setup, g, observed_only) {
  d <- setup$discrepancy[setup$gd[g], ]
  layout <- setup$dense
  at <- layout$grid[g, ]
  # B acts on residuals whitened by the base point (the noise alone): by
  # the AR(1) and Kronecker shortcuts for complete data
  whiten <- if (layout$kron) {
    w <- layout$A[[at$base]]
    function(M) list(whiten_rows(M, w, w$n_x, w$n_t))
  } else {
    point <- list(dense = c(layout[c("obs", "scale", "groups")],
                            list(A = layout$A[[at$base]])))
    function(M) whiten_groups(M, point)
  }
  basis <- layout$basis_all
  groups <- lapply(seq_along(layout$groups), function(k) {
    idx <- layout$groups[[k]]
    obs <- layout$obs[idx]
    cells <- if (observed_only) obs else which(setup$pattern$group == k)
    r <- layout$rot[[at$base]][[at$kernel]][[k]]
    list(cells = cells, L = basis[cells, , drop = FALSE] %*% r$T,
         HT = layout$H[[at$base]][[k]] %*% r$T,
         p = d$ratio / (1 + d$ratio * r$d))
  })
  list(whiten = whiten, groups = groups)
}
