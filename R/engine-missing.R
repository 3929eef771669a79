# Missing cells on the full field's kernel. A field with missing cells (and
# one noise group, no discrepancy) keeps the Kronecker structure on the grid
# of the x settings and coordinates t that hold a measurement (the others
# are dropped: the marginal of R_x (x) R_t over them is R_x (x) R_t
# restricted, and the AR(1) over t stays AR(1) with lag coefficients from the
# gaps), and within that grid the cells that are still missing are handled
# by a Schur complement in the same pass over the runs as the full field's
# forms (src/quadratic_forms.cpp, Missing). Relative sd (cell means of
# replicates) scale the residuals. The dense factors (dense_factors()) stay
# the reference every other part of the package reads; this is only how C
# is computed, in one pass over the runs with the tiled kernel instead of a
# product per grid point on the reference BLAS (34 times the full field's
# time, issue 36).

# The plan of a setup's missing cells (setup$masked), or NULL when its noise
# pattern is not one this path takes (several noise groups, a discrepancy).
# `t` the library's coordinates; `pattern` as noise_pattern().
missing_plan <- function(setup, t, pattern) {
  if (length(pattern$labels) != 1L) return(NULL)
  n_x <- dim(setup$Rx_chol)[1]
  n_t <- length(t)
  observed <- matrix(pattern$observed, n_t, n_x)
  keep_t <- which(rowSums(observed) > 0)
  keep_x <- which(colSums(observed) > 0)
  cells <- observed[keep_t, keep_x, drop = FALSE]
  column <- as.vector(outer(keep_t, (keep_x - 1L) * n_t, "+"))
  scale <- if (is.null(pattern$sd_mean)) rep(1, length(column)) else 1 / pattern$sd_mean[column]
  scale[!cells] <- 1
  s <- scale_unit(t)[keep_t]
  phi <- vapply(setup$rho_t, function(rho) if (rho == 0) diff(s) * 0 else rho^diff(s),
                numeric(length(s) - 1L))
  phi <- matrix(phi, length(s) - 1L, length(setup$rho_t))
  x <- reduced_x_inverses(setup$Rx_chol, keep_x)
  fill <- missing_fill(cells, s, setup$rho_t)
  list(column = ifelse(as.vector(cells), column, 0L) - 1L, scale = scale, Rx_inv = x$inv,
       phi = phi, fill = fill, offset = pattern$pure_ss[1],
       logdet_kron = length(keep_t) * x$logdet[setup$gx] +
         length(keep_x) * colSums(log1p(-phi^2))[setup$gt])
}

# R_x^-1 of the settings kept, at each x grid point, and log|R_x| of them.
reduced_x_inverses <- function(Rx_chol, keep_x) {
  G_x <- dim(Rx_chol)[3]
  inv <- array(0, c(length(keep_x), length(keep_x), G_x))
  logdet <- numeric(G_x)
  for (gx in seq_len(G_x)) {
    R <- crossprod(matrix(Rx_chol[, , gx], dim(Rx_chol)[1]))[keep_x, keep_x, drop = FALSE]
    U <- chol(R)
    inv[, , gx] <- chol2inv(U)
    logdet[gx] <- 2 * sum(log(diag(U)))
  }
  list(inv = inv, logdet = logdet)
}

# Each missing cell of the reduced grid (`cells`: TRUE where observed, one
# column per setting) filled with the AR(1) conditional mean of its setting
# given the nearest observed coordinates before and after it (the others add
# nothing: the AR(1) is Markov), at each rho_t value: with correlations
# phi_1 (to the one before) and phi_2 (to the one after), the weights are
# phi_1 (1 - phi_2^2) / (1 - phi_1^2 phi_2^2) and phi_2 (1 - phi_1^2) / (...);
# phi_1 or phi_2 alone with one neighbour. Cells 0-based, -1 for none.
missing_fill <- function(cells, s, rho_t) {
  n_t <- nrow(cells)
  miss <- which(!cells)
  G_t <- length(rho_t)
  out <- list(before = integer(length(miss)), after = integer(length(miss)),
              w_before = matrix(0, length(miss), G_t), w_after = matrix(0, length(miss), G_t))
  for (k in seq_along(miss)) {
    a <- (miss[k] - 1L) %/% n_t
    b <- (miss[k] - 1L) %% n_t + 1L
    seen <- which(cells[, a + 1L])
    b1 <- max(c(0L, seen[seen < b]))
    b2 <- min(c(n_t + 1L, seen[seen > b]))
    out$before[k] <- if (b1 > 0L) a * n_t + b1 - 1L else -1L
    out$after[k] <- if (b2 <= n_t) a * n_t + b2 - 1L else -1L
    p1 <- if (b1 > 0L) ifelse(rho_t == 0, 0, rho_t^(s[b] - s[b1])) else rep(0, G_t)
    p2 <- if (b2 <= n_t) ifelse(rho_t == 0, 0, rho_t^(s[b2] - s[b])) else rep(0, G_t)
    denom <- 1 - p1^2 * p2^2
    out$w_before[k, ] <- p1 * (1 - p2^2) / denom
    out$w_after[k, ] <- p2 * (1 - p1^2) / denom
  }
  out
}

# C of outputs Y (runs in rows) under a setup with missing cells
# (setup$masked): the effective form of its one noise group, pure error
# included, as the dense path gives it.
masked_quad_forms <- function(Y, y_field, plan, threads = griddy_threads()) {
  y_cells <- y_field[pmax(plan$column + 1L, 1L)]
  y_cells[plan$column < 0L] <- 0
  masked_quad_forms_cpp(Y, y_cells, plan$column, plan$scale, plan$Rx_inv, plan$phi,
                        plan$fill$before, plan$fill$after, plan$fill$w_before,
                        plan$fill$w_after, plan$offset, threads)
}

# log|Sigma_oo| of the observed cells at every grid point of a setup with a
# missing-cell plan: the reduced grid's Kronecker log-determinant plus
# log|P_mm| (src/quadratic_forms.cpp), the same as the dense factors'
# without their O(n^3) per grid point (for tests and checks).
masked_logdet <- function(plan) {
  plan$logdet_kron + missing_logdet_cpp(plan$column, plan$Rx_inv, plan$phi)
}
