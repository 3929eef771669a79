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

# ---- grid points --------------------------------------------------------------

# Everything about the correlation grid, computed once per fit: the grid (one
# row per point), the Cholesky factor and inverse of R_x for each combination
# of x correlations, the AR(1) lag coefficients phi for each rho_t, and
# log|R_g| per grid point (eq. 10, 12-13). Grid point g combines x combination
# gx = (g - 1) %% G_x + 1 with rho_t value gt = (g - 1) %/% G_x + 1.
correlation_setup <- function(library, rho_x, rho_t, x_power = 2) {
  if (!is.numeric(x_power) || length(x_power) != 1L || !is.finite(x_power) ||
      x_power <= 0 || x_power > 2) {
    griddy_abort("`x_power` must be a single number in (0, 2]; received ",
                 paste(format(x_power), collapse = ", "), ".")
  }
  grids <- rho_grids(library, rho_x, rho_t)
  n_x <- lib_n_x(library)
  n_t <- lib_n_t(library)
  combos <- expand.grid(grids$x, KEEP.OUT.ATTRS = FALSE)
  Rx_chol <- array(0, c(n_x, n_x, nrow(combos)))
  Rx_inv <- Rx_chol
  logdet_x <- numeric(nrow(combos))
  for (gx in seq_len(nrow(combos))) {
    rho <- unlist(combos[gx, , drop = FALSE])
    U <- tryCatch(chol(corr_x(lib_x(library), rho, x_power)), error = function(e) NULL)
    if (is.null(U) || any(diag(U) < 1e-7)) {
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
  list(Rx_chol = Rx_chol, Rx_inv = Rx_inv, phi = phi,
       logdet = n_t * logdet_x[gx] + n_x * logdet_t[gt], gx = gx, gt = gt,
       x_power = x_power, rho_x = grids$x, rho_t = grids$t)
}

# One grid point g: its R_x factor (upper Cholesky U, R_x = U'U) and inverse,
# its AR(1) lag coefficients and log|R_g|.
grid_point <- function(setup, g) {
  n_x <- dim(setup$Rx_chol)[1]
  list(Rx_chol = matrix(setup$Rx_chol[, , setup$gx[g]], n_x, n_x),
       Rx_inv = matrix(setup$Rx_inv[, , setup$gx[g]], n_x, n_x),
       phi = setup$phi[, setup$gt[g]], logdet = setup$logdet[g])
}

n_grid_points <- function(setup) length(setup$logdet)

# Whiten residual rows (vectors in library order, blocks of n_t by x setting)
# under grid point `point`, so that squared norms are the quadratic forms in
# R_g^-1: AR(1) innovations over t (src/grid_posterior.h), then U'^-1 over x.
# `over_x = FALSE` stops after the AR(1) step.
whiten_rows <- function(M, point, n_x, n_t, over_x = TRUE) {
  M <- ar1_whiten_rows_cpp(M, point$phi, n_x)
  if (n_x > 1L && over_x) {
    A_x <- backsolve(point$Rx_chol, diag(n_x))          # U^-1, so R_x^-1 = A_x A_x'
    M <- matrix(matrix(M, nrow(M) * n_t, n_x) %*% A_x, nrow(M), n_x * n_t)
  }
  M
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
# emulator, see library_refined.R) comes with an extra log-determinant
# (attribute "extra_logdet"); it is folded into C, exactly for tau
# integrated out under the Gamma(a, b) prior:
#   -(a + n/2) log(b + C''/2) = -(a + n/2) log(b + C/2) - extra/2  when
#   C'' = (2b + C) exp(extra / (2a + n)) - 2b.
misfit_table <- function(library, y_field, setup, prior) {
  C <- withCallingHandlers(lib_quad_forms(library, y_field, setup), error = function(e) {
    if (grepl("misfit is not finite", conditionMessage(e), fixed = TRUE)) {
      abort_overflow(y_field)
    }
  })
  fold_extra_logdet(C, prior, length(y_field))
}

# The quadratic forms of outputs Y (runs in rows) held in memory, each run's
# covariance R_g: for runs that are not (or not yet) a library's.
plain_quad_forms <- function(Y, y_field, setup) {
  quad_forms_cpp(Y, y_field, setup$Rx_inv, setup$phi)
}

fold_extra_logdet <- function(C, prior, n_obs) {
  extra <- attr(C, "extra_logdet")
  attr(C, "extra_logdet") <- NULL
  if (is.null(extra) || all(extra == 0)) return(C)
  (2 * prior$rate + C) * exp(extra / (2 * prior$shape + n_obs)) - 2 * prior$rate
}

abort_overflow <- function(y_field) {
  griddy_abort("A misfit is not a finite number: the squared differences between the ",
               "field data and the outputs overflow double precision (largest |field ",
               "value| ", format(max(abs(y_field)), digits = 3), "). Rescale the outputs and ",
               "the field data (e.g. to other units) before calibrating.", class = "numeric")
}

# ---- the log joint ------------------------------------------------------------

# log p(y | run i, grid point g) with tau integrated out: C a matrix (runs x
# grid points) with `logdet` one per column, or a vector with one `logdet`.
# The leave-out variants of diagnose_gap() pass the quadratic forms, data
# size and log-determinant of the data left in.
collapsed_log_lik <- function(C, n_obs, logdet, prior) {
  ll <- -(prior$shape + n_obs / 2) * log(prior$rate + C / 2) +
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
# b^a Gamma(a + n/2) / (Gamma(a) (2 pi)^(n/2)). For an improper prior (b = 0)
# the b^a factor is left out: the result then holds up to a constant shared
# by every model with the same prior, which is enough to compare them
# (diagnose_gap()) but is no evidence (posterior_exact() reports NA).
log_evidence_constant <- function(prior, n_obs) {
  a <- prior$shape
  b <- prior$rate
  (if (b > 0) a * log(b) else 0) - lgamma(a) + lgamma(a + n_obs / 2) -
    n_obs / 2 * log(2 * pi)
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

# The posterior of a calibration problem (see calibration_problem()): the
# joint probabilities over (run, grid point) and the log evidence.
grid_posterior <- function(problem) {
  lj <- collapsed_log_joint(problem$C, problem$n_obs, problem$setup$logdet, problem$prior,
                            problem$log_prior_run, problem$log_prior_grid)
  log_norm <- log_sum_exp(lj)
  list(joint = exp(lj - log_norm),
       log_evidence = if (problem$prior$rate > 0) log_norm else NA_real_)
}
