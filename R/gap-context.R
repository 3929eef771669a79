# The fitted noise model per correlation grid point, and the runs x grid points
# pieces every part of diagnose_gap() reads (see ?diagnose_gap).

# The fit's noise model, one entry per correlation grid point: the grid
# point (engine.R) with the dense inverse correlations that the
# block checks need. The data are the observed points `obs` (library order;
# all of them for complete data). Under a noise pattern (missing cells,
# relative sd) a grid point also holds P = (S R_g S)_oo^-1 over the observed
# points and, per x setting, the Cholesky factor of P_BB for B its observed
# cells (NULL for a setting with none): the Kronecker shortcuts do not hold
# there.
gap_context <- function(fit) {
  lib <- fit$library
  setup <- fit$setup
  n_x <- lib_n_x(lib)
  n_t <- lib_n_t(lib)
  obs <- observed_outputs(setup, n_x * n_t)
  setting_pos <- lapply(seq_len(n_x), function(k) block_positions(obs, k, seq_len(n_t), n_t))
  points <- lapply(seq_len(n_grid_points(setup)), function(g) {
    fitted <- grid_point(setup, g)
    point <- c(fitted, list(Pt = ar1_precision(fitted$phi, n_t),
                            log_prior = fit$log_prior_grid[g]))
    if (!is.null(fitted$dense)) {
      point$P <- dense_precision(fitted)
      point$setting_chol <- lapply(setting_pos, function(pos) {
        if (length(pos) > 0L) chol(point$P[pos, pos, drop = FALSE])
      })
    }
    point
  })
  list(n_x = n_x, n_t = n_t, n = fit$n_obs, y = fit$y_field, prior = fit$prior,
       points = points, setup = setup, x = lib_x(lib), t = lib_t(lib), theta = lib_theta(lib),
       logdet = setup$logdet, log_prior_grid = fit$log_prior_grid,
       obs = obs, sd = setup$pattern$sd, sd_y = data_sd(setup, n_x * n_t),
       is_dense = !is.null(noise_layout(setup)), setting_pos = setting_pos)
}

# The relative sd of each data value (library order, NA where missing): a
# replicated cell's mean has its own (1 / sqrt(n_rep) without sd), a cell
# measured once its measurement's; NULL when every value has the noise's.
# What the predictive checks of held-out values scale by (`sd` is that of
# one measurement, which "other"'s discrepancy is scaled by).
data_sd <- function(setup, n) {
  layout <- noise_layout(setup)
  if (is.null(layout$scale)) return(NULL)
  sd <- rep(NA_real_, n)
  sd[layout$obs] <- 1 / layout$scale
  sd
}

# The AR(1) precision over t, A'A for A the whitening (innovations) operator
# of ar1_whiten_rows_cpp(): A is lower bidiagonal, so A'A is tridiagonal and
# is filled from A's two diagonals (no n_t^3 product); its diagonal and
# off-diagonal are kept as attributes "diag" and "off" for products in
# O(n_t) (ar1_precision_times()).
ar1_precision <- function(phi, n_t) {
  if (n_t == 1L) {
    d <- ar1_whiten_rows_cpp(matrix(1), phi, 1L)[1]^2
    return(structure(matrix(d), diag = d, off = numeric()))
  }
  # whitening the odd and the even unit indicators reads A's diagonal a_ii
  # and sub-diagonal a_(i,i-1) at once (each row of A has those two entries)
  odd <- seq_len(n_t) %% 2L == 1L
  U <- ar1_whiten_rows_cpp(rbind(as.numeric(odd), as.numeric(!odd)), phi, 1L)
  d <- ifelse(odd, U[1, ], U[2, ])
  sub <- ifelse(odd, U[2, ], U[1, ])[-1]                  # a_(i,i-1), i = 2..n_t
  P <- diag(d^2 + c(sub^2, 0))
  off <- sub * d[-1]                                      # (A'A)_(i-1,i) = a_(i,i-1) a_ii
  P[cbind(1:(n_t - 1L), 2:n_t)] <- off
  P[cbind(2:n_t, 1:(n_t - 1L))] <- off
  structure(P, diag = diag(P), off = off)
}

# P = (S R_g S)_oo^-1 over the observed points of a dense grid point with one
# noise group: R_oo^-1 = A A' (dense_factors()), scaled by 1/sd on both sides.
dense_precision <- function(point) {
  d <- point$dense
  P <- tcrossprod(d$A[[1]])
  if (!is.null(d$scale)) P <- P * outer(d$scale, d$scale)
  P
}

# The positions, in the vector of observed points `obs`, of the observed
# cells of x setting k at t indices W (a block restricted to what was
# measured; empty when none was).
block_positions <- function(obs, k, W, n_t) {
  pos <- match((k - 1L) * n_t + W, obs)
  pos[!is.na(pos)]
}

# Per model: Q (runs x grid points), its log joint lj, the leave-setting-out
# pieces D (runs x grid points x settings) and the outputs. `C`, when given,
# is the model's own table of misfits (a refined library's, with the
# prediction error of its predicted runs): it sets the posterior and evidence
# (lj), while the leave-out algebra (Q, D, lj_plain) works on the plain
# quadratic forms, which leave-out identities hold for. Every step is a pass over the runs x data points (no
# per-run loop, no n x n algebra per run).
#
# `shared`, when given, is the terms of a model whose runs are the first rows
# of this one (a candidate's zero level is the refined base): `Y` then holds
# only the rows after them (the first rows' outputs are shared$Y, not copied;
# term_outputs() reads either), their leave-out pieces and plain misfits are
# taken from `shared`, and only the other rows are computed. The residuals
# y - Y are not kept (a runs x data points matrix): what reads them forms
# them from Y.
gap_terms <- function(ctx, Y, log_prior_run, Q = NULL, C = NULL, shared = NULL) {
  head <- if (is.null(shared)) 0L else nrow(shared$D)
  J <- head + nrow(Y)
  if (is.null(Q)) Q <- rbind(shared$Q, plain_quad_forms(Y, ctx$y, ctx$setup))
  apart <- settings_apart(ctx)
  # residuals y - eta, runs in rows (not needed for the pieces of settings apart)
  D <- if (apart) setting_quad_forms(ctx, Y) else
    leave_setting_pieces(ctx, rep(ctx$y, each = nrow(Y)) - Y)
  if (head > 0L) {
    D_rest <- D
    D <- array(0, c(J, length(ctx$points), ctx$n_x))
    D[seq_len(head), , ] <- shared$D
    D[head + seq_len(J - head), , ] <- D_rest
  }
  lj_plain <- collapsed_log_joint(Q, ctx$n, ctx$logdet, ctx$prior, log_prior_run,
                                  ctx$log_prior_grid)
  lj <- if (is.null(C)) lj_plain else
    collapsed_log_joint(C, ctx$n, ctx$logdet, ctx$prior, log_prior_run, ctx$log_prior_grid)
  list(Y = Y, head_Y = shared$Y, Q = Q, lj = lj, lj_plain = lj_plain, D = D,
       log_prior_run = log_prior_run)
}

# sum_i w_i Y_i over a model's runs (every output), whether or not its first
# rows are shared (see gap_terms()): one pass over the outputs, no copy.
term_mean <- function(tm, w) {
  if (is.null(tm$head_Y)) return(drop(crossprod(w, tm$Y)))
  head <- seq_len(nrow(tm$head_Y))
  drop(crossprod(w[head], tm$head_Y) + crossprod(w[-head], tm$Y))
}

# The outputs of a model's runs `rows` (indices over all its runs) at columns
# `cols`, whether or not its first rows are shared (see gap_terms()).
term_outputs <- function(tm, rows, cols) {
  if (is.null(tm$head_Y)) return(tm$Y[rows, cols, drop = FALSE])
  head <- nrow(tm$head_Y)
  top <- rows <= head
  out <- matrix(0, length(rows), length(cols))
  out[top, ] <- tm$head_Y[rows[top], cols, drop = FALSE]
  out[!top, ] <- tm$Y[rows[!top] - head, cols, drop = FALSE]
  out
}

# The leave-setting-out pieces D (runs x grid points x settings) of the
# residuals E (runs in rows), one grid point at a time.
leave_setting_pieces <- function(ctx, E) {
  D <- array(0, c(nrow(E), length(ctx$points), ctx$n_x))
  for (g in seq_along(ctx$points)) D[, g, ] <- setting_pieces(ctx, E, ctx$points[[g]])
  D
}

# Whether the settings are independent under every grid point's noise model
# (complete data, no relative sd, R_x^-1 diagonal: no rho_x): then a
# setting's leave-out piece is its own quadratic form (setting_quad_forms()).
settings_apart <- function(ctx) {
  !ctx$is_dense && is.null(ctx$sd) && all(vapply(ctx$points, function(point) {
    R <- point$Rx_inv
    all(R[row(R) != col(R)] == 0)
  }, logical(1)))
}

# setting_pieces() at every grid point at once when the settings are apart
# (settings_apart()): with R^-1 = R_x^-1 (x) Pt and R_x^-1 diagonal, D_k =
# (R_x^-1)_kk e_k' Pt e_k, and e_k' Pt e_k is setting k's own misfit under
# the AR(1) precision alone, which the compiled misfit pass gives at every
# rho_t at once (quad_forms_cpp() with one x setting): one pass per setting
# over the outputs Y, without residuals or whitened copies. The same numbers
# as setting_pieces() to rounding. Returns runs x grid points x settings.
setting_quad_forms <- function(ctx, Y) {
  n_t <- ctx$n_t
  setup <- ctx$setup
  G <- length(ctx$points)
  one <- array(1, c(1L, 1L, 1L))
  D <- array(0, c(nrow(Y), G, ctx$n_x))
  for (k in seq_len(ctx$n_x)) {
    cols <- (k - 1L) * n_t + seq_len(n_t)
    # one column per rho_t value; grid point g uses column gt[g]
    Qt <- quad_forms_cpp(Y[, cols, drop = FALSE], ctx$y[cols], one, setup$phi, griddy_threads())
    for (g in seq_len(G)) {
      D[, g, k] <- ctx$points[[g]]$Rx_inv[k, k] * Qt[, setup$gt[g]]
    }
  }
  D
}

# D_k = h_B' P_BB^-1 h_B (runs x settings) at one grid point, for B the
# observed cells of setting k and h = P e, P the inverse noise correlation
# over the observed points.
setting_pieces <- function(ctx, E, point) {
  J <- nrow(E)
  n_x <- ctx$n_x
  n_t <- ctx$n_t
  if (ctx$is_dense) {
    H <- E[, ctx$obs, drop = FALSE] %*% point$P
    D <- matrix(0, J, n_x)
    for (k in seq_len(n_x)) {
      U <- point$setting_chol[[k]]
      if (is.null(U)) next                            # no observed cell: nothing left out
      pos <- ctx$setting_pos[[k]]
      D[, k] <- colSums(backsolve(U, t(H[, pos, drop = FALSE]), transpose = TRUE)^2)
    }
    return(D)
  }
  # with R^-1 = R_x^-1 (x) Pt, D_k = v_k' Pt v_k / (R_x^-1)_kk for v_k = sum_l
  # (R_x^-1)_lk e_l: the AR(1) innovations of v_k, squared and summed over
  # setting k's columns (one product with the settings' indicator)
  V <- if (!identical(unname(point$Rx_inv), diag(n_x))) {
    matrix(matrix(E, J * n_t, n_x) %*% point$Rx_inv, J, n_x * n_t)
  } else E
  W <- whiten_rows(V, point, n_x, n_t, over_x = FALSE)
  setting <- outer(rep(seq_len(n_x), each = n_t), seq_len(n_x), "==") + 0
  ((W * W) %*% setting) * rep(1 / diag(point$Rx_inv), each = J)
}
