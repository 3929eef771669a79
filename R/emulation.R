# The emulation-error model: one error model, one truncation rule, one
# algebra, one noise plug-in.
#
# A run predicted by an emulator (an emulated library's runs, the runs
# refine() adds without a simulator) carries the emulator's error
# delta_i ~ N(0, kappa_i V). V = U diag(lambda) U' holds the leading
# principal directions of the emulator's leave-one-out residuals
# (emulation_error_model(), error_rank()); kappa_i >= 0 is the prediction's
# variance relative to the design's mean leave-one-out variance (0 at a
# simulated run). With the plug-in noise variance s2 (posterior_noise_var(),
# one per noise group) the covariance tau^-1 R_g + kappa_i V is written
# tau^-1 (R_g + kappa_i V / s2): still conjugate in tau, so the engine is
# unchanged.
#
# The algebra (Woodbury and the matrix determinant lemma), used alike by the
# misfit table (emulated_group_forms()) and diagnose_gap()'s leave-block
# pieces (emulated_inverse(), emulated_block()). With F = U diag(sqrt(lambda /
# s2)) over the observed points, P = R_g^-1 = W'W, F'PF = Q diag(gamma) Q'
# (error_eigen()) and A = P F Q:
#   S_i^-1 = P - A diag(kappa_i / (1 + kappa_i gamma)) A'
#   r' S_i^-1 r = r'P r - sum_m kappa_i (A'r)_m^2 / (1 + kappa_i gamma_m)
#   log|S_i| - log|R_g| = sum_m log(1 + kappa_i gamma_m).
#
# Why an emulated library's runs share one kappa (emulated_kappa()): kappa_i
# depends on the design, not on the data, and rises towards the design's
# edges, where the design runs are sparse. When the data sit further from
# every run than the noise and the error allow (a discrepancy, or an
# emulator worse than its own estimate), the Gaussian's log density
# -q / (2 v) - log(v) / 2 rises with the variance v as long as v is below
# the squared misfit q: the log-determinant penalises a larger error only
# once it exceeds the misfit. A run-dependent kappa then pulls the
# posterior to where the emulator knows least (on the spot-weld data, 54%
# of it on the design's upper edge). The error still widens the likelihood,
# at the size it has where the posterior is: one kappa, the posterior mean
# of kappa_i under the posterior without the error (under the posterior
# with it, kappa would follow the mass the error pulls, and feed it).

# ---- the error model ------------------------------------------------------------

# The share of the residuals' second moment the leading directions must
# hold: 99.99%.
error_energy <- 0.9999

# How many of the decreasing values `values` (variances) to keep: as many as
# hold error_energy of their sum, at most max_rank.
error_rank <- function(values, max_rank = 50L) {
  energy <- cumsum(values) / sum(values)
  min(which(energy >= error_energy)[1], max_rank, length(values))
}

# The error model of an emulator from its leave-one-out residuals `E` (runs
# x outputs): the leading principal directions of their second moment (not
# centred: a shared bias is error too); `noise_var` is the plug-in noise
# variance (one per noise group).
emulation_error_model <- function(E, noise_var, max_rank = 50L) {
  if (nrow(E) == 0L || all(E == 0)) return(NULL)
  E <- E / sqrt(nrow(E))
  s <- leading_svd(E, max_rank + error_oversample)
  # the share of the energy is of all the residuals' second moment, not of
  # the leading values only
  energy <- cumsum(s$d^2) / sum(E^2)
  m <- min(which(energy >= error_energy)[1], max_rank, min(dim(E)), na.rm = TRUE)
  list(U = s$v[, seq_len(m), drop = FALSE], lambda = s$d[seq_len(m)]^2,
       noise_var = noise_var)
}

# Directions beyond the most kept that leading_svd() computes, so that the
# kept ones are resolved from the rest.
error_oversample <- 30L

# The leading k singular values d and right vectors v of E. A full SVD
# computes every left vector too (1.3 s for 1,224 runs x 480 outputs on the
# reference LAPACK); for a larger E the k leading eigenvectors of its smaller
# Gram matrix span the leading subspace, and the SVD of E in that subspace
# (Rayleigh-Ritz) gives the values and vectors to rounding of E itself, not
# of its squares (about a third of the time).
leading_svd <- function(E, k) {
  n <- nrow(E)
  p <- ncol(E)
  if (min(n, p) <= 2L * k) return(svd(E, nu = 0L))
  product <- function(X, B) tiled_matmul_cpp(X, B, griddy_threads())
  if (p <= n) {
    V0 <- eigen(product(t(E), E), symmetric = TRUE)$vectors[, seq_len(k)]
    s <- svd(product(E, V0), nu = 0L)
    return(list(d = s$d, v = V0 %*% s$v))
  }
  U0 <- eigen(product(E, t(E)), symmetric = TRUE)$vectors[, seq_len(k)]
  s <- svd(product(t(U0), E), nu = 0L)
  list(d = s$d, v = s$v)
}

# An emulated library's error model over its outputs (see ?emulated_library).
# The leave-one-out residuals are standardised first, each by its own
# predictive sd relative to their mean (standardised_loo()). In the joint
# form V = (S^1/2 K_x S^1/2) (x) V_t, whose eigenpairs are the products of
# its factors'.
design_error_model <- function(gp, var) {
  vt <- emulation_error_model(standardised_loo(gp), NA_real_)
  if (gp$mode == "theta" || is.null(vt)) return(vt)
  s <- colMeans(var)
  s <- if (mean(s) > 0) s / mean(s) else rep(1, length(s))
  kx <- eigen(sqrt(s) * t(sqrt(s) * design_gp_setting_cor(gp)), symmetric = TRUE)
  lambda <- outer(pmax(kx$values, 0), vt$lambda)
  order <- order(lambda, decreasing = TRUE)
  m <- error_rank(lambda[order])
  keep <- order[seq_len(m)]
  kx_j <- row(lambda)[keep]
  vt_j <- col(lambda)[keep]
  U <- vapply(seq_len(m), function(j) {
    kronecker(kx$vectors[, kx_j[j]], vt$U[, vt_j[j]])
  }, numeric(gp$n_x * gp$n_t))
  list(U = matrix(U, ncol = m), lambda = lambda[keep], noise_var = NA_real_)
}

# The design's leave-one-out residuals, each divided by its predictive sd
# over their root mean variance. Unstandardised, the few runs at the
# design's edges, where leaving one out is extrapolating, dominate the
# second moment: V's leading direction is then the difference between the
# edge runs' outputs and the interior's, and the error forgives the edge
# runs' misfit in exactly that direction. kappa_i carries the size of each
# prediction's error, V only its shape.
standardised_loo <- function(gp) {
  v <- gp$loo_var / mean(gp$loo_var)
  if (!all(is.finite(v)) || any(v <= 0)) return(gp$loo)
  gp$loo / sqrt(v)
}

# ---- the algebra ------------------------------------------------------------------

# The eigen-pieces of a whitened error factor WF (points x rank):
# WF'WF = Q diag(gamma) Q', and WF Q.
error_eigen <- function(WF) {
  eg <- eigen(crossprod(WF), symmetric = TRUE)
  list(WFQ = WF %*% eg$vectors, gamma = pmax(eg$values, 0))
}

# kappa_i / (1 + kappa_i gamma_m) (runs x rank), and the runs' extra
# log-determinants sum_m log(1 + kappa_i gamma_m).
error_shrink <- function(kappa, gamma) outer(kappa, gamma, function(k, g) k / (1 + k * g))
error_logdet <- function(kappa, gamma) rowSums(log1p(outer(kappa, gamma)))

# Quadratic forms of predicted runs (see the top of this file), folded over
# the noise groups: list(C, logdet = the extra log-determinants), runs x grid
# points.
emulated_quad_forms <- function(y, y_field, setup, err, kappa, n_x, n_t) {
  # a discrepancy: every grid point at once, through its factors
  if (isTRUE(setup$dense$lowrank)) return(discrepancy_emulated_forms(y, y_field, setup, err, kappa))
  C <- matrix(0, nrow(y), n_grid_points(setup))
  extra <- C
  for (g in seq_len(n_grid_points(setup))) {
    f <- emulated_group_forms(y, y_field, setup, err, kappa, n_x, n_t, g)
    C[, g] <- fold_groups(f$C, setup)
    extra[, g] <- f$logdet
  }
  list(C = C, logdet = extra)
}

# emulated_quad_forms() at grid point g, before folding: list(C = runs x
# noise groups, logdet). W whitens the observed points (divided by their
# sd under a noise pattern); with noise groups the error applies within
# each group, V restricted to its points and s2 its noise variance.
emulated_group_forms <- function(y, y_field, setup, err, kappa, n_x, n_t, g) {
  if (isTRUE(setup$dense$lowrank)) {
    return(discrepancy_emulated_group_forms(y, y_field, setup, err, kappa, g))
  }
  point <- grid_point(setup, g)
  whiten <- function(M) {
    if (is.null(point$dense)) list(whiten_rows(M, point, n_x, n_t)) else whiten_groups(M, point)
  }
  Wr <- whiten(matrix(y_field, nrow(y), length(y_field), byrow = TRUE) - y)
  WU <- whiten(t(err$U))
  s2 <- rep_len(err$noise_var, length(Wr))
  # the plain forms (with the replicates' pure error), less the part the
  # emulation error explains
  C <- group_quad_forms(y, y_field, setup, g)
  extra <- numeric(nrow(y))
  for (k in seq_along(Wr)) {
    eg <- error_eigen(t(WU[[k]] * sqrt(err$lambda / s2[k])))
    e <- Wr[[k]] %*% eg$WFQ
    C[, k] <- C[, k] - rowSums(e^2 * error_shrink(kappa, eg$gamma))
    extra <- extra + error_logdet(kappa, eg$gamma)
  }
  list(C = C, logdet = extra)
}

# A predicted run's covariance relative to R_g over the data points,
# S = R_g + V V' (V = F sqrt(kappa), run_emulation()): h = S^-1 r,
# Q = r'S^-1 r, logdet = log|S| - log|R_g|, and for its blocks A = P V Q and
# the shrinkage 1 / (1 + gamma). P is applied by apply_precision().
emulated_inverse <- function(ctx, point, e, err) {
  PV <- apply(err$V, 2, function(v) apply_precision(ctx, point, v))
  eg <- eigen(crossprod(err$V, PV), symmetric = TRUE)
  gamma <- pmax(eg$values, 0)
  A <- PV %*% eg$vectors
  shrink <- error_shrink(1, gamma)[1, ]
  h <- apply_precision(ctx, point, e) - drop(A %*% (shrink * crossprod(A, e)))
  # Q as the run's misfit C has it: with the replicates' pure error, which
  # every leave-block-out piece keeps (plain runs' Q holds it too)
  list(A = A, shrink = shrink, h = h, Q = sum(e * h) + sum(ctx$setup$pure_ss),
       logdet = error_logdet(1, gamma))
}

# Its leave-block pieces: (S^-1)_BB = P_BB - A_B diag(shrink) A_B'.
emulated_block <- function(wood, P_BB, pos) {
  A <- wood$A[pos, , drop = FALSE]
  U <- chol(P_BB - A %*% (wood$shrink * t(A)))
  z <- backsolve(U, wood$h[pos], transpose = TRUE)
  list(D = sum(z^2), Q = wood$Q, logdet = wood$logdet, logdet_BB = 2 * sum(log(diag(U))))
}

# Which runs of a library were predicted, and the error model of each (NULL
# when none was): diagnose_gap()'s checks and the noise groups' forms take
# those runs under their own covariance. See lib_prediction_errors().
run_errors <- function(library) {
  if (is.null(library)) NULL else lib_prediction_errors(library)
}

# The prediction error of run j as V (data points x rank, S = R_g + V V'
# over the observed points `obs`), or NULL when the run was simulated. One
# noise variance over the points: the groups' pooled (noise_var_pooled()).
run_emulation <- function(emulation, j, obs) {
  if (is.null(emulation) || j %in% emulation$replaced) return(NULL)
  if (j <= emulation$n_base) {
    if (is.null(emulation$base)) return(NULL)
    err <- emulation$base$error
    kappa <- emulation$base$kappa
  } else {
    k <- j - emulation$n_base
    err <- emulation$errors[[emulation$round[k]]]
    kappa <- emulation$kappa[k]
  }
  if (is.null(err) || kappa <= 0) return(NULL)
  s2 <- mean(err$noise_var)
  list(V = err$U[obs, , drop = FALSE] %*%
         diag(sqrt(kappa * err$lambda / s2), length(err$lambda)))
}

# The quadratic forms of each noise group (runs x groups) of library rows
# `runs` at grid point g, with the emulation error of predicted runs: what
# the draws of each group's precision and its posterior mean need.
run_group_forms <- function(problem, runs, g) {
  library <- problem$library
  Ck <- group_quad_forms(lib_outputs(library, runs), problem$y_field, problem$setup, g)
  for (part in predicted_parts(library, runs)) {
    Ck[part$at, ] <- emulated_group_forms(lib_outputs(library, runs[part$at]), problem$y_field,
                                          problem$setup, part$error, part$kappa,
                                          lib_n_x(library), lib_n_t(library), g)$C
  }
  Ck
}

# The quadratic forms of library rows `rows` under any setup (another grid,
# a discrepancy's), each predicted run under its own covariance as the
# library keeps it for its field data (run_errors()): list(C = runs x grid
# points folded over the noise groups, extra_logdet), what
# fold_extra_logdet() takes. The gap screen weighs a fit's runs this way.
predicted_forms <- function(library, rows, y_field, setup) {
  Y <- lib_outputs(library, rows)
  C <- plain_quad_forms(Y, y_field, setup)
  extra <- matrix(0, nrow(C), ncol(C))
  for (part in predicted_parts(library, rows)) {
    em <- emulated_quad_forms(Y[part$at, , drop = FALSE], y_field, setup, part$error,
                              part$kappa, lib_n_x(library), lib_n_t(library))
    C[part$at, ] <- em$C
    extra[part$at, ] <- em$logdet
  }
  list(C = C, extra_logdet = extra)
}

# Library rows `rows` grouped by the error model that predicted them: a
# list with, per model, the positions `at` in `rows`, the `error` model and
# each run's `kappa`. Simulated runs, and predicted ones a simulator
# replaced, are in none.
predicted_parts <- function(library, rows) {
  em <- run_errors(library)
  if (is.null(em)) return(list())
  # model 1 the base library's (one shared kappa), model r + 1 round r's
  errors <- c(list(em$base$error), em$errors)
  model <- integer(length(rows))
  kappa <- numeric(length(rows))
  in_base <- rows <= em$n_base
  if (!is.null(em$base)) {
    model[in_base] <- 1L
    kappa[in_base] <- em$base$kappa
  }
  added <- rows[!in_base] - em$n_base
  model[!in_base] <- em$round[added] + 1L
  kappa[!in_base] <- em$kappa[added]
  model[rows %in% em$replaced] <- 0L
  parts <- lapply(setdiff(unique(model), 0L), function(m) {
    at <- which(model == m)
    if (is.null(errors[[m]])) NULL else list(at = at, error = errors[[m]], kappa = kappa[at])
  })
  Filter(Negate(is.null), parts)
}

# ---- the noise plug-in --------------------------------------------------------------

# The posterior mean of 1/tau under the problem's prior: (b + C/2) / (a + n/2
# - 1) averaged over the exact posterior over (run, grid point); with noise
# groups, that of each 1/tau_k (over the runs that carry the posterior: all
# but 1e-12 of it). `state` holds the problem and its joint posterior.
posterior_noise_var <- function(state) {
  pr <- state$problem
  sizes <- pr$setup$group_sizes
  denom <- pmax(pr$prior$shape + sizes / 2 - 1, 0.5)
  if (length(sizes) == 1L) {
    # in blocks of columns: no temporaries as large as C (8 GB at 10^6 runs x
    # 1,000 grid points), nor a call per column (the same sums: colSums()
    # adds a column as sum() does)
    weighted_C <- sum(unlist(lapply(column_blocks(ncol(pr$C), nrow(pr$C)), function(cols) {
      colSums(state$joint[, cols, drop = FALSE] * pr$C[, cols, drop = FALSE])
    })))
    return((pr$prior$rate * sum(state$joint) + weighted_C / 2) / denom)
  }
  total <- numeric(length(sizes))
  for (g in seq_len(ncol(state$joint))) {
    runs <- which(state$joint[, g] > 1e-12 * max(state$joint))
    if (length(runs) == 0L) next
    Ck <- run_group_forms(pr, runs, g)
    total <- total + colSums(state$joint[runs, g] * (pr$prior$rate + Ck / 2))
  }
  total / sum(state$joint) / denom
}

# Consecutive column blocks of a rows x n matrix, each of about 2^17 cells.
column_blocks <- function(n, rows) {
  size <- max(1L, floor(2^17 / max(rows, 1)))
  unname(split(seq_len(n), ceiling(seq_len(n) / size)))
}

# One noise variance for all observed points: the groups' own (see
# posterior_noise_var()) averaged over the points.
noise_var_pooled <- function(problem, s2) {
  sum(s2 * problem$setup$group_sizes) / sum(problem$setup$group_sizes)
}

# The noise variance the emulator's error cannot inflate, pooled over the
# groups: the replicates' pure error when there are enough of them (their
# spread about their cell means owes nothing to any run); otherwise the
# smaller of the plug-in s2 (the posterior mean of 1/tau, which a poor
# emulator inflates by its misfit) and the best run's misfit per data point
# under the model with the error (C, extra log-determinant folded), which
# the error can only lower.
#
# Both of those still hold the emulator's misfit when no run fits (a useless
# emulator once scored 0.72 against a noise sd it had inflated five-fold),
# so the field data's roughness bounds them too (roughness_noise_var()).
reference_noise_var <- function(setup, s2, C, rough = NULL) {
  n <- sum(setup$group_sizes)
  df <- setup$group_sizes - group_cells(setup)
  if (sum(df) >= 5L) return(sum(setup$pure_ss) / sum(df))
  min(sum(s2 * setup$group_sizes) / n, max(min(C), 0) / n, rough)
}

# The noise variance from the roughness of the best run's residuals: their
# third differences along the data (within each x setting, or each noise
# group's observed points), after whitening under the most probable grid
# point. White noise gives a third difference the variance 20 sigma^2
# (choose(6, 3)); a smooth misfit (the emulator's error, a discrepancy)
# barely reaches it, so neither can inflate this estimate. On a robust scale
# (MAD), since an edge between settings makes a few differences large. NULL
# with fewer than 10 differences.
roughness_order <- 3L

roughness_noise_var <- function(state) {
  problem <- state$problem
  lib <- problem$library
  n_x <- lib_n_x(lib)
  n_t <- lib_n_t(lib)
  g <- if (is.null(state$joint)) 1L else which.max(colSums(state$joint))
  resid <- matrix(problem$y_field - lib_outputs(lib, which.max(state$p))[1, ], 1)
  point <- grid_point(problem$setup, g)
  sequences <- if (is.null(point$dense)) {
    w <- whiten_rows(resid, point, n_x, n_t, over_x = FALSE)
    split(w[1, ], rep(seq_len(n_x), each = n_t))
  } else {
    lapply(whiten_groups(resid, point), function(W) W[1, ])
  }
  d <- unlist(lapply(sequences, function(v) {
    if (length(v) > roughness_order) diff(v, differences = roughness_order)
  }))
  if (length(d) < 10L) return(NULL)
  stats::mad(d)^2 / choose(2L * roughness_order, roughness_order)
}

# Every round's prediction error on the scale of the current posterior's
# noise variance, and the posterior again. The scale is a plug-in; the first
# rounds' posteriors, still on a coarse library, overstate the noise by the
# library's misfit, which would understate the prediction error relative to
# it; so each round puts all rounds on the newest estimate, a few times, to
# a fixed point. An emulated base library's runs are restated with them
# (its shared kappa kept).
restate_noise_var <- function(state, times = 3L) {
  for (i in seq_len(times)) {
    problem <- state$problem
    old <- lib_noise_var(problem$library)
    if (length(old) == 0L) return(state)
    s2 <- posterior_noise_var(state)
    same <- length(old) %% length(s2) == 0L && !anyNA(old) && all(abs(old - s2) <= 0.01 * s2)
    if (same) return(state)
    problem$library <- lib_with_noise_var(problem$library, s2, problem$y_field)
    rows <- which(lib_predicted(problem$library))
    problem$C[rows, ] <- fold_extra_logdet(
      lib_run_quad_forms(problem$library, rows, problem$y_field, problem$setup),
      problem$prior, problem$n_obs)
    state <- refine_state(problem)
  }
  state
}

# Whether the best run fits the replicated field data: its misfit under the
# emulator's error beyond the replicates' pure error, per measured cell,
# over the pure error's mean square (an F statistic on the cells and the
# pure error's degrees of freedom). NULL without enough replicates. When no
# run fits (a discrepancy, or a simulator or data in error), the emulator's
# error is the likelihood's only slack, and shapes the posterior.
lack_of_fit <- function(setup, best) {
  cells <- sum(group_cells(setup))
  df <- sum(setup$group_sizes) - cells
  if (df < 5L) return(NULL)
  pure <- sum(setup$pure_ss)
  f <- max(best - pure, 0) / cells / (pure / df)
  list(f = f, cells = cells, df = df, p_value = stats::pf(f, cells, df, lower.tail = FALSE))
}

lack_of_fit_p <- 0.001

warn_lack_of_fit <- function(lof) {
  if (is.null(lof) || !is.finite(lof$p_value) || lof$p_value > lack_of_fit_p) return()
  griddy_warn("No run of the emulated library fits the field data: the best run's misfit, ",
              "with the emulator's error allowed for, is ", format(lof$f, digits = 2),
              " times the replicates' pure error per measured cell (F test on ", lof$cells,
              " and ", lof$df, " degrees of freedom, p = ", format(lof$p_value, digits = 2),
              "). The emulator's error then shapes the posterior; the simulator may need a ",
              "discrepancy, or the data or the runs a check.", class = "lack_of_fit")
}

# ---- how well the emulator predicts near the posterior ---------------------------------

# How well the library predicts its own runs where the posterior is: the
# leave-one-out residuals' root mean square over the 2p + 1 library runs
# nearest the most probable run, over a noise sd the emulator's error cannot
# inflate (reference_noise_var()). Above 1 the predicted runs there are off by
# more than the noise, and the intervals rest on the emulator's error model,
# an estimate.
emulation_error_ratio <- function(emulator, state) {
  theta <- as.matrix(lib_theta(state$problem$library))
  loo_error_near(emulator, theta[which.max(state$p), ],
                 reference_noise_var(state$problem$setup, posterior_noise_var(state),
                                     state$problem$C, roughness_noise_var(state)))
}

# The root mean square of an emulator's leave-one-out residuals (`loo`, at
# the runs `loo_theta`) over the 2p + 1 runs nearest `mode` (distances on
# columns scaled by the runs' ranges), over the noise sd sqrt(s2).
loo_error_near <- function(emulator, mode, s2) {
  th <- emulator$loo_theta
  width <- pmax(apply(th, 2, function(v) diff(range(v))), 1e-300)
  d2 <- colSums(((t(th) - mode) / width)^2)
  near <- order(d2)[seq_len(min(2L * ncol(th) + 1L, length(d2)))]
  sqrt(mean(emulator$loo[near, ]^2) / s2)
}
