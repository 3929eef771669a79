# The grid posterior: the one place that says what a correlation grid point is
# and what the posterior over (library run, grid point) is. calibrate()'s
# sampler (through src/grid_posterior.h), posterior_exact(), the summary's
# checks, predict() and every part of diagnose_gap() use these functions.
#
# Model (thesis ch. 3.2, App. A-B): y = g_i + e, e ~ N(0, tau^-1 R_g),
# R_g = R_x (x) R_t, tau ~ Gamma(a, b). With C_ig = (y - g_i)' R_g^-1 (y - g_i)
# and n data points, tau integrates out (Gamma-normal):
#   log p(i, g | y) = log pi_i + log pi_g - log|R_g| / 2
#                     - (a + n/2) log(b + C_ig / 2) + const.
#
# The noise pattern generalises this (see noise_pattern()): only the n
# observed points enter (R_g restricted to them), each may have a known
# relative sd (covariance tau^-1 S R_g S), and the points may fall into noise
# groups k with precisions tau_k ~ Gamma(a, b) of their own, independent
# between groups. Then, summing over groups,
#   log p(y | i, g) = sum_k [-(a + n_k/2) log(b + C_igk/2)] - log|S R S| / 2,
# which is -(a + n/2) log(b + C_eff/2) for the effective quadratic form
#   C_eff = 2 exp(sum_k w_k log(b + C_igk/2)) - 2b,  w_k = (a + n_k/2) / (a + n/2),
# so the sampler (src/) sees one C as before and its draws stay exact.
# Complete data without sd or groups keep the Kronecker/AR(1) shortcuts
# (quad_forms_cpp); any other pattern uses dense factors of the observed
# block of each group, computed once per grid point (dense_factors()).

# ---- grid points --------------------------------------------------------------

# Everything about the correlation grid, computed once per fit: the grid (one
# row per point), the Cholesky factor and inverse of R_x for each combination
# of x correlations, the AR(1) lag coefficients phi for each rho_t, and
# log|R_g| per grid point (eq. 10, 12-13). Grid point g combines x combination
# gx = (g - 1) %% G_x + 1 with rho_t value gt = (g - 1) %/% G_x + 1.
#
# `pattern` (noise_pattern()) is NULL for complete data with one tau and no
# sd; otherwise the setup also holds `dense`, the dense factors of every grid
# point, and log|R_g| is that of the observed, scaled and grouped covariance.
correlation_setup <- function(library, rho_x, rho_t, x_power = 2, pattern = NULL,
                              discrepancy = NULL) {
  if (!is.numeric(x_power) || length(x_power) != 1L || !is.finite(x_power) ||
      x_power <= 0 || x_power > 2) {
    griddy_abort("`x_power` must be a single number in (0, 2]; received ",
                 paste(format(x_power), collapse = ", "), ".")
  }
  grids <- rho_grids(library, rho_x, rho_t)
  n_x <- lib_n_x(library)
  n_t <- lib_n_t(library)
  combos <- expand.grid(grids$x, KEEP.OUT.ATTRS = FALSE)
  R_x <- corr_x_grid(lib_x(library), grids$x, x_power)
  Rx_chol <- array(0, c(n_x, n_x, nrow(combos)))
  Rx_inv <- Rx_chol
  logdet_x <- numeric(nrow(combos))
  for (gx in seq_len(nrow(combos))) {
    U <- tryCatch(chol(R_x[[gx]]), error = function(e) NULL)
    if (is.null(U) || any(diag(U) < 1e-7)) {
      rho <- unlist(combos[gx, , drop = FALSE])
      griddy_abort("R_x is numerically singular at ", paste0(names(rho), " = ", rho,
                   collapse = ", "), ": the x settings are too close for this ",
                   "correlation. Use smaller values in `rho_x`.", class = "numeric")
    }
    Rx_chol[, , gx] <- U
    Rx_inv[, , gx] <- chol2inv(U)
    logdet_x[gx] <- 2 * sum(log(diag(U)))
  }
  phi <- matrix(0, max(n_t - 1L, 0L), length(grids$t))
  for (gt in seq_along(grids$t)) phi[, gt] <- ar1_phi(lib_t(library), grids$t[gt])
  singular <- colSums(phi >= 1) > 0
  if (any(singular)) {
    griddy_abort("`rho_t` value(s) ", show_some(format(grids$t[singular], digits = 17)),
                 " give neighbouring outputs a correlation that rounds to 1, so R_t is ",
                 "singular; use values further from 1.", class = "input")
  }
  logdet_t <- colSums(log1p(-phi^2))
  gx <- rep(seq_len(nrow(combos)), times = length(grids$t))
  gt <- rep(seq_along(grids$t), each = nrow(combos))
  setup <- list(Rx_chol = Rx_chol, Rx_inv = Rx_inv, phi = phi,
                logdet = n_t * logdet_x[gx] + n_x * logdet_t[gt], gx = gx, gt = gt,
                x_power = x_power, rho_x = grids$x, rho_t = grids$t,
                x_class = same_matrix_class(Rx_chol), group_sizes = n_x * n_t)
  if (is.null(pattern)) return(setup)
  disc <- if (!is.null(discrepancy)) discrepancy_points(discrepancy, library)
  kernels <- if (!is.null(disc)) discrepancy_kernel_factors(library, attr(disc, "kernels"))
  setup$dense <- dense_factors(setup, lib_t(library), pattern, disc, kernels)
  setup$logdet <- setup$dense$logdet
  setup$dense$logdet <- NULL
  if (!is.null(disc)) {
    # grid point g = (d - 1) G + h: base point h (rho) within discrepancy point d
    G <- length(setup$gx)
    setup$gd <- rep(seq_len(nrow(disc)), each = G)
    setup$gx <- rep(setup$gx, nrow(disc))
    setup$gt <- rep(setup$gt, nrow(disc))
    setup$discrepancy <- disc
  }
  # a group's size counts its replicates: its observed cells plus their
  # pure-error degrees of freedom; the pure error's sum of squares enters
  # every run's form in group_quad_forms()
  setup$group_sizes <- lengths(setup$dense$groups) + pattern$pure_df
  setup$pure_ss <- pattern$pure_ss
  setup$fold_prior <- pattern$prior
  setup$pattern <- pattern[c("observed", "sd", "group", "labels")]
  # missing cells and replicates of one noise group: C on the full field's
  # kernel (engine-missing.R)
  if (is.null(disc)) setup$masked <- missing_plan(setup, lib_t(library), pattern)
  setup
}

# For each slice of a stack of matrices, the first slice equal to it (to
# 1e-10): grid points whose R_x coincide share a correlation structure.
# Slices that are equal have sums within `window` of each other, so each
# slice is compared only with the earlier ones whose sums are that close
# (found in the sorted sums), not with all of them: 1,000 slices take
# milliseconds rather than a minute.
same_matrix_class <- function(stack) {
  flat <- matrix(stack, ncol = dim(stack)[3])  # one column per slice
  n <- ncol(flat)
  cls <- seq_len(n)
  if (n < 2L) return(cls)
  key <- colSums(flat)
  window <- nrow(flat) * (1e-10 + 64 * .Machine$double.eps * max(abs(flat)))
  o <- order(key)
  sorted <- key[o]
  for (j in seq_len(n)[-1]) {
    near <- o[seq(findInterval(key[j] - window, sorted, left.open = TRUE) + 1L,
                  findInterval(key[j] + window, sorted))]
    for (i in sort(near[near < j & cls[near] == near])) {
      if (max(abs(flat[, i] - flat[, j])) <= 1e-10) {
        cls[j] <- i
        break
      }
    }
  }
  cls
}

# The dense factors of a noise pattern at every grid point. For each noise
# group k, with U_k the upper Cholesky factor of the observed block R_kk of
# R_g, the inverse covariance is R_kk^-1 = A_k A_k' with A_k = U_k^-1: kept
# as `W` (a list over groups per grid point), with `rot` (grid point g's
# entry of W) and column weights `w` (NULL: none), the shape
# plain_quad_forms() and grid_point() read. A discrepancy has factors of its
# own (discrepancy_dense_factors()). An observed block that is numerically
# singular (settings too close for the correlation) is an error. Also
# returned: the log-determinant of the covariance S R S restricted to the
# observed points and grouped.
dense_factors <- function(setup, t, pattern, disc = NULL, kernels = NULL) {
  # a discrepancy: low-rank factors of its kernels (discrepancy-engine.R)
  if (!is.null(disc)) return(discrepancy_dense_factors(setup, t, pattern, disc, kernels))
  layout <- observed_layout(pattern)
  G <- length(setup$logdet)
  W <- vector("list", G)
  logdet <- numeric(G)
  for (g in seq_len(G)) {
    U <- observed_noise_cholesky(setup, g, t, layout$obs, layout$groups)
    logdet[g] <- sum(vapply(U, function(u) 2 * sum(log(diag(u))), 0)) + layout$log_sd
    W[[g]] <- lapply(U, function(u) backsolve(u, diag(nrow(u))))
  }
  c(layout[c("obs", "scale", "groups")],
    list(W = W, rot = seq_len(G), w = vector("list", G), logdet = logdet))
}

# The observed outputs of a noise pattern (`obs`, library order), its noise
# groups (positions in `obs`, one element per group, named by label), the
# outputs' 1/sd (`scale`, NULL without relative sd) and log|S|^2 over the
# cells plus the constant that makes it the replicates' own
# (field_layout()): what dense_factors() and discrepancy_dense_factors()
# both start from.
observed_layout <- function(pattern) {
  obs <- which(pattern$observed)
  groups <- split(seq_along(obs), factor(pattern$group[obs], seq_along(pattern$labels)))
  names(groups) <- pattern$labels
  list(obs = obs, groups = groups,
       scale = if (!is.null(pattern$sd_mean)) 1 / pattern$sd_mean[obs],
       log_sd = if (is.null(pattern$sd_mean)) 0 else
         2 * sum(log(pattern$sd_mean[obs])) + pattern$log_sd_excess)
}

# The data a setup's noise model sees, the same at every grid point: the
# observed library outputs `obs` (library order), their 1/sd `scale` (NULL
# without relative sd or replicates) and the noise groups `groups`
# (positions in `obs`, one element per group). NULL for a setup in the
# Kronecker case (complete data, one group, no sd), where every output is
# observed.
noise_layout <- function(setup) {
  if (is.null(setup$dense)) return(NULL)
  setup$dense[c("obs", "scale", "groups")]
}

# The observed library outputs of a setup (library order): every one of the
# `n` outputs in the Kronecker case.
observed_outputs <- function(setup, n) {
  layout <- noise_layout(setup)
  if (is.null(layout)) seq_len(n) else layout$obs
}

# One grid point g: its R_x factor (upper Cholesky U, R_x = U'U) and inverse,
# its AR(1) lag coefficients and log|R_g|; for a noise pattern that breaks
# the Kronecker structure, also `dense`: the observed points, their 1/sd, the
# noise groups and each group's factor A_k (see dense_factors()).
grid_point <- function(setup, g) {
  n_x <- dim(setup$Rx_chol)[1]
  point <- list(Rx_chol = matrix(setup$Rx_chol[, , setup$gx[g]], n_x, n_x),
                Rx_inv = matrix(setup$Rx_inv[, , setup$gx[g]], n_x, n_x),
                phi = setup$phi[, setup$gt[g]], logdet = setup$logdet[g])
  if (!is.null(setup$dense)) {
    point$dense <- c(setup$dense[c("obs", "scale", "groups")], list(A = dense_point_factors(setup$dense, g)))
  }
  point
}

# The factors A_k of dense grid point g (see dense_factors()).
dense_point_factors <- function(dense, g) {
  if (isTRUE(dense$lowrank)) return(discrepancy_point_factors(dense, g))
  W <- dense$W[[dense$rot[g]]]
  w <- dense$w[[g]]
  if (is.null(w)) return(W)
  Map(function(M, v) sweep(M, 2, sqrt(v), "*"), W, w)
}

n_grid_points <- function(setup) length(setup$logdet)

# The observed cells of each noise group (group_sizes less the replicates'
# pure-error degrees of freedom): every cell, one group, for a Kronecker
# setup.
group_cells <- function(setup) {
  layout <- noise_layout(setup)
  if (is.null(layout)) setup$group_sizes else lengths(layout$groups)
}

# Whiten residual rows (vectors in library order, blocks of n_t by x setting)
# under grid point `point`, so that squared norms are the quadratic forms in
# R_g^-1: AR(1) innovations over t (src/grid_posterior.h), then U'^-1 over x.
# `over_x = FALSE` stops after the AR(1) step. Under a dense grid point the
# rows come back with one column per observed point (grouped, see
# whiten_groups()).
whiten_rows <- function(M, point, n_x, n_t, over_x = TRUE) {
  if (!is.null(point$dense)) {
    if (!over_x) {
      griddy_abort("A grid point of missing, scaled or grouped data has no AR(1)-only ",
                   "whitening.", class = "unsupported")
    }
    return(do.call(cbind, unname(whiten_groups(M, point))))
  }
  # phi = 0 (independent t) whitens to M itself, exactly: skip the copy
  # (and R_x = I, rho_x = 0, the product)
  if (any(point$phi != 0)) M <- ar1_whiten_columns_cpp(M, point$phi, n_x)
  if (n_x > 1L && over_x && !is_identity(point$Rx_chol)) {
    A_x <- backsolve(point$Rx_chol, diag(n_x))          # U^-1, so R_x^-1 = A_x A_x'
    M <- matrix(matrix(M, nrow(M) * n_t, n_x) %*% A_x, nrow(M), n_x * n_t)
  }
  M
}

# Rows of M (full library-order vectors) whitened group by group under a
# dense grid point: the observed columns, divided by their sd, times A_k.
whiten_groups <- function(M, point) {
  Map(`%*%`, group_columns(M, point$dense), point$dense$A)
}

# Is A the identity matrix (a factor of independent noise, rho = 0)? Then
# rotating by it is a copy, not an O(N n^2) product.
is_identity <- function(A) nrow(A) == ncol(A) && all(A == diag(nrow(A)))

# The observed columns of rows M (full library-order vectors), divided by
# their sd, cut into the noise groups of dense factors `d`: what the groups'
# factors multiply.
group_columns <- function(M, d) {
  M <- M[, d$obs, drop = FALSE]
  if (!is.null(d$scale)) M <- sweep(M, 2, d$scale, "*")
  if (length(d$groups) == 1L) return(list(M))
  lapply(d$groups, function(idx) M[, idx, drop = FALSE])
}

# Draw rows of N(0, R_g) noise under grid point `point`: the inverse of
# whiten_rows().
colour_rows <- function(Z, point, n_x, n_t) {
  if (n_x > 1L) {
    Z <- matrix(matrix(Z, nrow(Z) * n_t, n_x) %*% point$Rx_chol, nrow(Z), n_x * n_t)
  }
  ar1_colour_rows_cpp(Z, point$phi, n_x)
}

# ---- the quadratic forms --------------------------------------------------------

# C (runs x grid points) of a library. Every backend computes it with
# quad_forms_cpp(), which stops on a non-finite misfit; here, for any backend,
# that error becomes one that says why: the outputs' scale overflows double
# precision (|y - g|^2 beyond 1.8e308), which would turn every weight into 0
# or NaN. (A backend whose outputs hold NA or Inf says so first, itself.)
#
# A run whose likelihood has a covariance of its own (a run predicted by an
# emulator, see library-refined.R) comes with an extra log-determinant,
# folded into C exactly for tau integrated out (fold_extra_logdet()).
# Returns list(C, emulation_error, plug_in): what the backend found beside C
# (misfit_parts()), for the problem (new_griddy_problem()).
misfit_table <- function(library, y_field, setup, prior) {
  forms <- withCallingHandlers(lib_quad_forms(library, y_field, setup), error = function(e) {
    if (grepl("misfit is not finite", conditionMessage(e), fixed = TRUE)) {
      abort_overflow(y_field)
    }
  })
  forms <- misfit_parts(forms)
  list(C = fold_extra_logdet(forms, prior, sum(setup$group_sizes)),  # every measurement
       emulation_error = forms$emulation_error, plug_in = forms$plug_in)
}

# The quadratic forms of outputs Y (runs in rows) held in memory, each run's
# covariance R_g: for runs that are not (or not yet) a library's. With noise
# groups, the effective C (fold_groups()). The Kronecker case runs on
# `threads` threads (see ?griddy_threads).
plain_quad_forms <- function(Y, y_field, setup, threads = griddy_threads()) {
  if (is.null(setup$dense)) {
    return(quad_forms_cpp(Y, y_field, setup$Rx_inv, setup$phi, threads))
  }
  if (!is.null(setup$masked)) return(masked_quad_forms(Y, y_field, setup$masked, threads))
  if (isTRUE(setup$dense$lowrank)) return(discrepancy_quad_forms(Y, y_field, setup))
  C <- matrix(0, nrow(Y), n_grid_points(setup))
  dense <- setup$dense
  # the residuals' observed, scaled columns of each group, cut once for all
  # rotations (a discrepancy grid has one rotation per length scale)
  blocks <- group_columns(matrix(y_field, nrow(Y), length(y_field), byrow = TRUE) - Y, dense)
  # one rotation per (rho, length scale) pair; each ratio lambda then
  # weighs its squared rotated residuals (dense_factors())
  for (r in unique(dense$rot)) {
    at <- which(dense$rot == r)
    Z2 <- Map(function(B, A) (if (is_identity(A)) B else B %*% A)^2, blocks, dense$W[[r]])
    weights <- lapply(seq_along(Z2), function(k) vapply(at, function(g) {
      if (is.null(dense$w[[g]])) rep(1, ncol(Z2[[k]])) else dense$w[[g]][[k]]
    }, numeric(ncol(Z2[[k]]))))
    if (length(Z2) == 1L) {
      # one noise group: its forms are C itself (no per-column copies)
      C[, at] <- Z2[[1]] %*% weights[[1]] + setup$pure_ss[1]
      next
    }
    Ck <- array(0, c(nrow(Y), length(at), length(Z2)))
    for (k in seq_along(Z2)) Ck[, , k] <- Z2[[k]] %*% weights[[k]] + setup$pure_ss[k]
    for (j in seq_along(at)) C[, at[j]] <- fold_groups(Ck[, j, ], setup)
  }
  if (!all(is.finite(C))) {
    griddy_abort("quad_forms: a misfit is not finite: the outputs hold NA, NaN or Inf, or ",
                 "overflow double precision.", class = "numeric")
  }
  C
}

# The quadratic forms of each noise group (runs x groups) at grid point g,
# over the observed points, each with its group's pure error (the
# replicates' sum of squares about their cell means, the same for every run;
# see field_layout()). Every per-group form (C, the tau_k draws, refine()'s
# new and emulated runs) is formed here.
group_quad_forms <- function(Y, y_field, setup, g) {
  resid <- matrix(y_field, nrow(Y), length(y_field), byrow = TRUE) - Y
  if (isTRUE(setup$dense$lowrank)) return(discrepancy_group_forms(resid, setup, g))
  point <- grid_point(setup, g)
  if (is.null(point$dense)) {
    n_x <- dim(setup$Rx_chol)[1]
    return(matrix(rowSums(whiten_rows(resid, point, n_x, length(y_field) %/% n_x)^2)))
  }
  Ck <- vapply(whiten_groups(resid, point), function(W) rowSums(W^2), numeric(nrow(Y)))
  sweep(matrix(Ck, nrow(Y)), 2, setup$pure_ss, "+")
}

# The effective quadratic form of the noise groups' forms Ck (runs x
# groups): -(a + n/2) log(b + C_eff/2) = sum_k -(a + n_k/2) log(b + C_k/2).
# One group: C itself.
fold_groups <- function(Ck, setup) {
  Ck <- matrix(Ck, ncol = length(setup$group_sizes))
  if (ncol(Ck) == 1L) return(Ck[, 1])
  a <- setup$fold_prior$shape
  b <- setup$fold_prior$rate
  w <- (a + setup$group_sizes / 2) / (a + sum(setup$group_sizes) / 2)
  2 * exp(log(b + Ck / 2) %*% w)[, 1] - 2 * b
}

# What a library's quadratic forms come with (lib_quad_forms()): a bare
# matrix C, or a list with C and, as a backend has them, `extra_logdet`
# (runs x grid points: the log-determinant a predicted run's own covariance
# adds, see library-refined.R), `emulation_error` (an emulated library's
# leave-one-out error near the posterior over the noise sd) and `plug_in`
# (an emulated library's noise plug-in for these data, lib_with_plug_in()).
# In a list rather than as attributes of C, which rbind() and subsetting
# drop. As a list, always.
misfit_parts <- function(forms) if (is.list(forms)) forms else list(C = forms)

# C with the extra log-determinant of `forms` (misfit_parts()) folded in:
# -(a + n/2) log(b + C''/2) = -(a + n/2) log(b + C/2) - extra/2 when
# C'' = (2b + C) exp(extra / (2a + n)) - 2b. (C may be most of memory: it is
# returned as it is when there is nothing to fold, not copied.)
fold_extra_logdet <- function(forms, prior, n_obs) {
  forms <- misfit_parts(forms)
  extra <- forms$extra_logdet
  if (is.null(extra) || all(extra == 0)) return(forms$C)
  (2 * prior$rate + forms$C) * exp(extra / (2 * prior$shape + n_obs)) - 2 * prior$rate
}

abort_overflow <- function(y_field) {
  griddy_abort("A misfit is not a finite number: the squared differences between the ",
               "field data and the outputs overflow double precision (largest |field ",
               "value| ", format(max(abs(y_field), na.rm = TRUE), digits = 3), "). Rescale the outputs and ",
               "the field data (e.g. to other units) before calibrating.", class = "numeric")
}

# ---- the log joint ------------------------------------------------------------

# log p(y | run i, grid point g) with tau integrated out: C a matrix (runs x
# grid points) with `logdet` one per column, or a vector with one `logdet`.
# `n_obs` is the data size, or the sizes of the noise groups (C then their
# effective form, fold_groups()). The leave-out variants of diagnose_gap()
# pass the quadratic forms, data size and log-determinant of the data left in.
collapsed_log_lik <- function(C, n_obs, logdet, prior) {
  ll <- -(prior$shape + sum(n_obs) / 2) * log(prior$rate + C / 2) +
    log_evidence_constant(prior, n_obs)
  if (is.matrix(ll)) sweep(ll, 2, logdet / 2, "-") else ll - logdet / 2
}

# log p(run i, grid point g, y): the log likelihood plus the log prior
# weights of the run and of the grid point. Its log-sum-exp is the log
# evidence.
collapsed_log_joint <- function(C, n_obs, logdet, prior, log_prior_run, log_prior_grid) {
  ll <- collapsed_log_lik(C, n_obs, logdet, prior)
  sweep(ll, 2, log_prior_grid, "+") + log_prior_run
}

# The constant of the Gamma-normal marginal likelihood:
# b^a Gamma(a + n/2) / (Gamma(a) (2 pi)^(n/2)), its log summed over noise
# groups when `n_obs` holds their sizes. For an improper prior (b = 0)
# the b^a factor is left out: the result then holds up to a constant shared
# by every model with the same prior, which is enough to compare them
# (diagnose_gap()) but is no evidence (posterior_exact() reports NA).
log_evidence_constant <- function(prior, n_obs) {
  a <- prior$shape
  b <- prior$rate
  sum((if (b > 0) a * log(b) else 0) - lgamma(a) + lgamma(a + n_obs / 2) -
    n_obs / 2 * log(2 * pi))
}

log_sum_exp <- function(v) {
  top <- max(v)
  if (!is.finite(top)) return(top)
  top + log(sum(exp(v - top)))
}

# Normalise a log joint into probabilities.
normalise_log <- function(lj) {
  exp(lj - log_sum_exp(lj))
}

# The same, kept in logs (no probability underflows to zero).
normalise_log_prob <- function(lj) lj - log_sum_exp(lj)

# log sum_i p(run i, grid point g, y) per grid point g, up to the constant
# shared by all (log_evidence_constant()): one column of C at a time, so no
# temporary is as large as C; in C++ (grid_log_mass_cpp()), with the
# arithmetic of collapsed_log_lik() and log_sum_exp() (test-engine.R's
# grid_log_mass_r(): the definition the C++ follows).
grid_log_mass <- function(problem) {
  n <- problem$n_obs
  prior <- problem$prior
  grid_log_mass_cpp(problem$C, prior$shape + sum(n) / 2, prior$rate,
                    log_evidence_constant(prior, n), problem$setup$logdet,
                    rep_len(as.numeric(problem$log_prior_run), nrow(problem$C)),
                    as.numeric(problem$log_prior_grid))
}

# The posterior of a calibration problem (see calibration_problem()): the
# posterior over runs (`run`) and over grid points (`grid`), the log
# evidence and, with `joint = TRUE`, the joint probabilities over (run, grid
# point): the log joint of collapsed_log_joint(), computed in
# src/exact_posterior.cpp in passes over C without temporaries as large as
# C, on griddy_threads() threads.
grid_posterior <- function(problem, joint = TRUE) {
  sizes <- problem$setup$group_sizes
  post <- grid_posterior_cpp(problem$C, problem$prior$shape + sum(sizes) / 2,
                             problem$prior$rate, problem$setup$logdet, problem$log_prior_run,
                             problem$log_prior_grid, joint, griddy_threads())
  log_norm <- post$log_norm + log_evidence_constant(problem$prior, sizes)
  list(joint = post$joint, run = post$run, grid = post$grid, log_mass = log_norm,
       log_evidence = if (problem$prior$rate > 0) log_norm else NA_real_)
}

# The upper Cholesky factor of each noise group's block of the observed
# points' correlation R_g at grid point g; a block numerically singular is
# an error.
observed_noise_cholesky <- function(setup, g, t, obs, groups) {
  R_x <- crossprod(setup$Rx_chol[, , setup$gx[g]])
  R <- kronecker(R_x, corr_t(t, setup$rho_t[setup$gt[g]]))[obs, obs, drop = FALSE]
  lapply(groups, function(idx) {
    U <- tryCatch(chol(R[idx, idx, drop = FALSE]), error = function(e) NULL)
    if (is.null(U) || any(diag(U) < 1e-7)) {
      griddy_abort("The correlation of the observed points is numerically singular at ",
                   "correlation grid point ", g, ": the observed x settings or output ",
                   "coordinates are too close for this correlation. Use smaller values ",
                   "in `rho_x` or `rho_t`.", class = "numeric")
    }
    U
  })
}
