# predict() at x settings the library does not hold (issue 34, item 1): the
# user's simulator run at the posterior's runs there, the discrepancy's
# Gaussian process extended to the new settings, and the noise of a new
# measurement. predict.griddy_fit() (fit-predict.R) sends a `newdata` with
# such settings here; its rows at library settings keep today's path, so
# their answer is today's exactly.
#
# With a discrepancy, delta at a new cell n given a run i, a grid point g and
# the noise precisions tau is the Gaussian conditional of delta-law.R with
# the kernel extended to n (one kernel over the library's cells and the new
# ones, built as discrepancy_kernels() builds it, so that its library block
# is the fit's kernel):
#   delta_n | y ~ N(lambda K_no Sigma^-1 r_i,
#                   tau^-1 (lambda K_nn - lambda K_no Sigma^-1 lambda K_on)).
# Far from every observed cell K_no -> 0: the mean reverts to 0 and the
# variance to the prior's lambda K_nn / tau, so an extrapolation's band
# widens by the discrepancy's whole prior spread. (An orthogonal
# discrepancy also carries to the new cells the change of theta it left to
# theta, see extended_projector(); that part grows with the simulator's
# sensitivities, not with the distance.)

# The rows of `newdata` at settings the library holds (their library rows)
# and NA at the others; NULL when there is nothing new (no newdata, or every
# row a library setting), and also when newdata is malformed, which
# predict_settings() then reports as it always has.
new_setting_rows <- function(lib, newdata) {
  x_lib <- lib_x(lib)
  if (is.null(newdata) || is.null(x_lib) || !is.data.frame(newdata) || nrow(newdata) < 1L ||
      !all(names(x_lib) %in% names(newdata))) {
    return(NULL)
  }
  nd <- as_numeric_matrix(newdata[names(x_lib)], "newdata")
  if (any(!is.finite(nd))) {
    griddy_abort("`newdata` must hold finite x settings; row(s) ",
                 show_some(which(rowSums(!is.finite(nd)) > 0)), " do not.")
  }
  hit <- match_setting_rows(as.data.frame(nd), x_lib)
  if (!anyNA(hit)) NULL else hit
}

# predict() of `fit` at newdata whose rows `hit` (new_setting_rows()) are
# partly or wholly new settings: the library's rows through today's path
# (same seed, so their answer is today's), the new ones through the
# simulator or the emulator (fit-predict-emulated.R), in newdata's order.
predict_new_settings <- function(fit, newdata, hit, level, ndraws, seed, discrepancy,
                                 simulator, run_mass) {
  lib <- fit$library
  new <- which(is.na(hit))
  x_new <- as.data.frame(as_numeric_matrix(newdata[new, names(lib_x(lib)), drop = FALSE],
                                           "newdata"))
  rownames(x_new) <- NULL
  if (is.null(simulator)) {
    reach <- design_reach(lib, x_new)
    if (!reach$ok) {
      griddy_abort(
        "`newdata` row(s) ", show_some(new), " (", show_some(setting_text(lib, x_new)),
        ") are not x settings of the library, which holds the simulator's outputs at its ",
        "own settings only, and ", reach$why, ". To predict there, pass ",
        "`simulator = function(theta, x)`: a function of a data frame of theta rows and a ",
        "data frame of x settings that returns one row per theta row with the outputs at ",
        "those settings (blocks of the library's ", lib_n_t(lib), " t value(s) by setting); ",
        "predict() runs it at the posterior's runs. Without a simulator, predict() ",
        "predicts at new settings only from the emulator of an emulated_library() whose ",
        "design's range of x holds them.", class = c("prediction", "input"))
    }
    require_package("RobustGaSP", "to predict from an emulated library's emulator")
    outputs <- function(theta) emulated_outputs(lib, theta, x_new)
  } else {
    if (!is.function(simulator)) {
      griddy_abort("`simulator` must be NULL or a function(theta, x); received ",
                   class(simulator)[1], ".")
    }
    n_out <- nrow(x_new) * lib_n_t(lib)
    outputs <- function(theta) simulate_at(simulator, theta, x_new, n_out)
  }
  assert_run_mass(run_mass)
  old <- which(!is.na(hit))
  parts <- list()
  if (length(old) > 0L) {
    parts$old <- stats::predict(fit, newdata = newdata[old, , drop = FALSE], level = level,
                                ndraws = ndraws, seed = seed, discrepancy = discrepancy)
  }
  parts$new <- with_seed(seed, predict_at_new(fit, x_new, level, ndraws, discrepancy,
                                              outputs, run_mass))
  if (!has_discrepancy(fit)) warn_unwidened_extrapolation(fit, x_new)
  n_t <- lib_n_t(lib)
  out <- do.call(rbind, unname(parts))
  out <- out[order(rep(c(old, new), each = n_t)), , drop = FALSE]
  rownames(out) <- NULL
  out
}

# A fit without a discrepancy assumes the simulator is right everywhere, so
# its band beyond the measured settings is the simulator's spread over the
# posterior plus noise: nothing in it grows with the distance from the
# measurements, and it can be as narrow outside as inside (measured in
# vignette("prediction"): 0.99-1.02 times without a discrepancy). Say so
# where it matters, at new settings outside the measured range.
warn_unwidened_extrapolation <- function(fit, x_new) {
  out <- outside_measured_range(fit, x_new)
  if (!any(out)) return(invisible())
  lib <- fit$library
  griddy_warn(
    "predict() extrapolates at ", show_some(setting_text(lib, x_new[out, , drop = FALSE])),
    ", outside the range of the measured settings (",
    measured_range_text(fit), "). This fit has no discrepancy, so its band there assumes ",
    "the simulator is right where no measurement tested it, and does not widen with the ",
    "distance from the measurements. For a band that carries what the simulator may miss ",
    "there, calibrate with `discrepancy = gp_discrepancy()` (with `zero_at`/`flat_at` if ",
    "you know where the gap vanishes).", class = "extrapolation")
}

# The x settings of the library that hold at least one measured cell.
measured_settings <- function(fit) {
  lib <- fit$library
  seen <- matrix(!is.na(fit$y_field), nrow = lib_n_t(lib))
  lib_x(lib)[colSums(seen) > 0L, , drop = FALSE]
}

# TRUE for each row of `x_new` with some x column outside the measured
# settings' range of that column (beyond rounding).
outside_measured_range <- function(fit, x_new) {
  x_seen <- measured_settings(fit)
  out <- logical(nrow(x_new))
  for (nm in names(x_seen)) {
    r <- range(x_seen[[nm]])
    tol <- 1e-8 * max(1, abs(r))
    out <- out | x_new[[nm]] < r[1] - tol | x_new[[nm]] > r[2] + tol
  }
  out
}

measured_range_text <- function(fit) {
  x_seen <- measured_settings(fit)
  paste(vapply(names(x_seen), function(nm) {
    paste0(nm, " from ", format(min(x_seen[[nm]]), digits = 4), " to ",
           format(max(x_seen[[nm]]), digits = 4))
  }, ""), collapse = ", ")
}

# "x = 5" for each row of a data frame of settings, over the library's x columns.
setting_text <- function(lib, x) {
  nm <- names(lib_x(lib))
  apply(as.matrix(x[nm]), 1, function(v) paste0(nm, " = ", v, collapse = ", "))
}

# The prediction's table at new settings `x_new` (a data frame over the
# library's x columns): predict()'s columns, `x` (the setting's library row)
# NA and `observed` NA. `outputs(theta)` gives the outputs at x_new of the
# runs `theta` (the simulator's, or an emulator's with attribute "sd", its
# predictive sd, whose error each draw then carries).
predict_at_new <- function(fit, x_new, level, ndraws, discrepancy, outputs, run_mass) {
  lib <- fit$library
  n_t <- lib_n_t(lib)
  probs <- c((1 - level) / 2, 1 - (1 - level) / 2)
  carry <- carrying_runs(fit, run_mass)
  G <- if (discrepancy) attr(attr(fit$setup$discrepancy, "kernels"), "sensitivity")
  near <- if (!is.null(G)) sensitivity_runs(lib, fit$draws$run, ncol(G))
  runs <- sort(unique(c(carry$run, near)))
  Y_all <- outputs(lib_theta(lib)[runs, , drop = FALSE])
  err_sd <- attr(Y_all, "sd")
  Y <- Y_all[match(carry$run, runs), , drop = FALSE]
  w <- carry$freq / sum(carry$freq)
  mean <- colSums(Y * w)
  # the kept draws whose runs were simulated (all but the left-out mass)
  kept <- which(fit$draws$run %in% carry$run)
  pick <- kept[unique(round(seq(1, length(kept), length.out = min(ndraws, length(kept)))))]
  drawn <- Y[match(fit$draws$run[pick], carry$run), , drop = FALSE]
  if (!is.null(err_sd)) {
    # the emulator's error at each draw's run: Gaussian, mean 0 (pointwise
    # bands need only its sd)
    s <- err_sd[match(fit$draws$run[pick], runs), , drop = FALSE]
    drawn <- drawn + s * stats::rnorm(length(s))
  }
  if (discrepancy) {
    E <- if (!is.null(G)) new_sensitivity_rows(lib, G, near,
                                               Y_all[match(near, runs), , drop = FALSE])
    delta <- new_delta(fit, x_new, kept, pick, E)
    mean <- mean + delta$mean
    drawn <- drawn + delta$draws
    bounds <- apply(drawn, 2, stats::quantile, probs = probs, names = FALSE)
  } else if (!is.null(err_sd)) {
    bounds <- apply(drawn, 2, stats::quantile, probs = probs, names = FALSE)
  } else {
    bounds <- apply(Y, 2, weighted_quantile, w = w, probs = probs)
  }
  noisy <- drawn + new_noise(fit, pick, nrow(x_new))
  pred <- apply(noisy, 2, stats::quantile, probs = probs, names = FALSE, na.rm = TRUE)
  cells <- stats::setNames(data.frame(rep(NA_integer_, nrow(x_new) * n_t)), setting_column(lib))
  cells <- cbind(cells, x_new[rep(seq_len(nrow(x_new)), each = n_t), , drop = FALSE],
                 t = rep(lib_t(lib), nrow(x_new)))
  rownames(cells) <- NULL
  cbind(cells, observed = NA_real_, mean = mean, lower = bounds[1, ], upper = bounds[2, ],
        pred_lower = pred[1, ], pred_upper = pred[2, ])
}

# The fewest distinct runs of the kept draws that carry `mass` of them
# (most visited first; all when mass = 1), in library order, with their
# draw counts. Runs visited once in 10^4 draws change a band by far less
# than its Monte Carlo error, and each costs a simulator call.
carrying_runs <- function(fit, mass) {
  freq <- tabulate(fit$draws$run, nbins = lib_n_runs(fit$library))
  visited <- which(freq > 0)
  o <- visited[order(-freq[visited], visited)]
  n <- which(cumsum(freq[o]) >= mass * sum(freq) - 1e-9)[1]
  run <- sort(o[seq_len(n)])
  list(run = run, freq = freq[run])
}

# The simulator's outputs at runs `theta` and settings `x_new` (one row per
# run), through the runner of simulate_library() and refine() (chunks, any
# future plan, each chunk checked). A failed run, or outputs of the wrong
# shape, stop the prediction: a band from the runs that happened to work
# would not be the posterior's.
simulate_at <- function(simulator, theta, x_new, n_out) {
  sim <- simulate_runs(simulator_caller(simulator, list(x_new)), theta, n_out, progress = FALSE)
  failure <- sim$failure
  if (is.null(failure)) return(sim$y)
  if (inherits(failure, "interrupt")) rlang::interrupt()
  rlang::abort(
    paste0("predict() ran `simulator(theta, x)` at ", nrow(theta), " posterior run(s) and the ",
           nrow(x_new), " new x setting(s) of `newdata`, expecting ", n_out, " outputs per ",
           "run (the library's t values at each setting, in blocks of t by setting): ",
           condition_text(failure)),
    class = c("griddy_error_simulator", grep("^griddy_error_", class(failure), value = TRUE),
              "griddy_error"),
    parent = failure, call = NULL)
}

# The noise group of every new cell (setting-major, blocks of t): the group
# of its t, which must be that t's group at every library setting (groups by
# t or one group). Groups by x setting give a new setting no precision.
new_cell_groups <- function(fit, n_new) {
  group <- fit$setup$pattern$group
  if (is.null(group)) return(rep(1L, n_new * lib_n_t(fit$library)))
  groups_by_t(group, lib_n_t(fit$library), n_new, "fit")
}

# The groups `group` (library order) of a fit's or stream's (`what`) cells
# at `n_new` new settings, each cell its t's group.
groups_by_t <- function(group, n_t, n_new, what) {
  by_t <- matrix(group, n_t)
  if (any(by_t != by_t[, 1])) {
    griddy_abort("predict() at new x settings needs noise groups that depend on t only ",
                 "(one group, or labels per output coordinate): this ", what, "'s groups ",
                 "vary over the x settings, so a new setting has no noise precision.",
                 class = "unsupported")
  }
  rep(by_t[, 1], n_new)
}

# The relative sd of one measurement at each new cell: the field's sd at its
# t where that is the same at every library setting, NA (so no predictive
# bound) where it is not; 1 without sd.
new_cell_sd <- function(fit, n_new) {
  sd <- fit$setup$pattern$sd
  n_t <- lib_n_t(fit$library)
  if (is.null(sd)) return(rep(1, n_new * n_t))
  by_t <- matrix(sd, n_t)
  same <- apply(by_t, 1, function(v) all(!is.na(v)) && all(v == v[1]))
  rep(ifelse(same, by_t[, 1], NA_real_), n_new)
}

# Noise of a new measurement at the new cells for the draws `pick` (one row
# per draw): N(0, tau_k^-1 S R_t S) within each noise group, R_t the AR(1)
# correlation over t at the draw's rho_t, independent across the new
# settings (a new measurement's noise is independent of the field's).
new_noise <- function(fit, pick, n_new) {
  n_t <- lib_n_t(fit$library)
  d <- fit$draws[pick, ]
  tau <- tau_matrix(fit, pick)
  group <- new_cell_groups(fit, n_new)
  out <- matrix(0, length(pick), n_new * n_t)
  for (g in unique(d$grid_point)) {
    rows <- which(d$grid_point == g)
    phi <- grid_point(fit$setup, g)$phi
    for (k in seq_len(ncol(tau))) {
      Z <- matrix(stats::rnorm(length(rows) * n_new * n_t), length(rows), byrow = TRUE)
      noise <- ar1_colour_rows_cpp(Z, phi, n_new) / sqrt(tau[rows, k])
      cols <- which(group == k)
      out[rows, cols] <- noise[, cols]
    }
  }
  sweep(out, 2, new_cell_sd(fit, n_new), "*")
}

# delta at the new cells: its exact mixture mean over the draws `kept` and
# draws of it at the draws `pick` (one row per draw). The laws are
# delta_law()'s, over the extended kernels, with the library's cells left
# out of every group and the new cells put in their groups.
new_delta <- function(fit, x_new, kept, pick, E = NULL) {
  lib <- fit$library
  n_lib <- lib_n_out(lib)
  n_new <- nrow(x_new) * lib_n_t(lib)
  setup <- fit$setup
  visited <- unique(fit$draws$grid_point[kept])
  used <- unique(setup$discrepancy$kernel[setup$gd[visited]])
  kernels <- extended_kernels(lib, attr(setup$discrepancy, "kernels"), x_new, E, used)
  setup$pattern$group <- c(rep(0L, n_lib), new_cell_groups(fit, nrow(x_new)))
  new_cols <- n_lib + seq_len(n_new)
  means <- function(law, runs) {
    resid <- cbind(run_residuals(fit, runs), matrix(0, length(runs), n_new))
    delta_means(law, resid)[, new_cols, drop = FALSE]
  }
  s1 <- numeric(n_new)
  draws <- matrix(0, length(pick), n_new)
  tau <- tau_matrix(fit, pick)
  for (g in visited) {
    law <- delta_law(setup, g, kernels)
    if (is.null(law)) next
    rows <- kept[fit$draws$grid_point[kept] == g]
    runs <- unique(fit$draws$run[rows])
    m <- means(law, runs)
    s1 <- s1 + colSums(m * tabulate(match(fit$draws$run[rows], runs), length(runs)))
    at <- which(fit$draws$grid_point[pick] == g)
    if (length(at) == 0L) next
    draws[at, ] <- m[match(fit$draws$run[pick[at]], runs), , drop = FALSE]
    for (k in seq_along(law$groups)) {
      grp <- law$groups[[k]]
      cells <- grp$cells - n_lib
      L <- sqrt_psd(delta_cov(grp))
      Z <- matrix(stats::rnorm(length(at) * ncol(L)), length(at))
      draws[at, cells] <- draws[at, cells] + tcrossprod(Z, L) / sqrt(tau[at, k])
    }
  }
  list(mean = s1 / length(kept), draws = draws)
}

# The discrepancy kernels over the library's cells and then the new cells
# (blocks of t by setting), one per row of `kernels`, built as
# discrepancy_kernels() builds the library's: the new settings scaled as
# the library's x columns are (so beyond [0, 1] outside its range),
# conditioned on the user's knowledge (K*, zero_at / flat_at), projected,
# scaled (S-GaSP). The library block is the fit's kernel; for an
# orthogonal discrepancy see extended_projector(), `E` its new rows. Only
# the kernels `used` are built (the others are NULL): a scaled discrepancy
# has one per ratio, each costing O(n^2) per observed cell.
extended_kernels <- function(library, kernels, x_new, E = NULL,
                             used = seq_len(nrow(kernels))) {
  x <- lib_x(library)
  n_x <- lib_n_x(library) + nrow(x_new)
  n_t <- lib_n_t(library)
  u <- vapply(names(x), function(nm) {
    ref <- x[[nm]]
    span <- max(ref) - min(ref)
    v <- c(ref, x_new[[nm]])
    if (span > 0) (v - min(ref)) / span else v * 0
  }, numeric(n_x))
  u <- matrix(u, n_x, ncol(x))
  d2_x <- Reduce(`+`, lapply(seq_len(ncol(u)), function(j) outer(u[, j], u[, j], "-")^2))
  s <- scale_unit(lib_t(library))
  d2_t <- outer(s, s, "-")^2
  project <- extended_projector(attr(kernels, "sensitivity"), E,
                                (n_x - lib_n_x(library)) * n_t)
  knowledge <- knowledge_observations(library, attr(kernels, "zero_at"),
                                      attr(kernels, "flat_at"))
  cells <- list(u = u[rep(seq_len(n_x), each = n_t), , drop = FALSE], t = rep(s, n_x),
                d = rep(0L, n_x * n_t))
  lapply(seq_len(nrow(kernels)), function(k) {
    if (!k %in% used) return(NULL)
    kernel_at(kernels, k, d2_x, d2_t, cells, knowledge, project)
  })
}

# An orthogonal discrepancy at new cells. On the library's cells it is
# P delta = delta - Q c, c = Q' delta the coefficients of delta on the
# sensitivities G = QR (theta's directions): the part of delta that a change
# of theta imitates, left to theta. The same change of theta moves a new
# cell by E c, E = G_new R^-1 (G_new the new cells' sensitivities), so there
# the discrepancy is delta_n - E c: the map T = I - [Q; E] [Q; 0]' over the
# library's cells and the new ones, and the kernel T K T'. Its library block
# is P K P, the fit's. Without `E` (no sensitivities at the new cells) the
# new cells keep delta itself, correlated with the projected discrepancy
# the data saw: a wider band, never a narrower one. `n_new` new cells.
extended_projector <- function(G, E, n_new) {
  if (is.null(G) || ncol(G) == 0L) return(identity)
  Q <- qr.Q(qr(G))
  if (is.null(E)) E <- matrix(0, n_new, ncol(Q))
  Q_all <- rbind(Q, E)
  Q_lib <- rbind(Q, matrix(0, n_new, ncol(Q)))
  function(K) {
    KQ <- K %*% Q_lib
    K - Q_all %*% t(KQ) - KQ %*% t(Q_all) + Q_all %*% (crossprod(Q_lib, KQ) %*% t(Q_all))
  }
}

# The runs whose outputs give the sensitivities at new cells: the 4p + 2 (at
# least 12) runs nearest the posterior's most visited run, on theta scaled
# to [0, 1], as discrepancy_sensitivity() takes them near the best-fitting
# run. `runs` the fit's drawn runs, `p` the sensitivities' count.
sensitivity_runs <- function(lib, runs, p) {
  theta <- scaled_theta(lib)
  mode <- which.max(tabulate(runs, nbins = lib_n_runs(lib)))
  k <- min(nrow(theta), max(4L * p + 2L, 12L))
  nearest_runs(theta[mode, , drop = FALSE], theta, k)$idx[1, ]
}

# The library's theta, each varying column scaled to [0, 1] (the constant
# ones left out).
scaled_theta <- function(lib) {
  theta <- as.matrix(lib_theta(lib))
  span <- apply(theta, 2, function(v) diff(range(v)))
  theta <- sweep(sweep(theta, 2, apply(theta, 2, min)), 2, pmax(span, 1e-300), "/")
  theta[, span > 0, drop = FALSE]
}

# E of extended_projector(): the new cells' move under the change of theta
# that moves the library's cells by Q (G = QR, the fit's sensitivities).
# The slopes of a linear fit on theta over the runs `near`, of the library's
# outputs (S_lib) and of the new outputs `Y_new` (S_new), give the change of
# theta A = S_lib^+ Q (least squares; exactly R^-1 when the fit's slopes
# are these), and E = S_new A. NULL (no E) when the slopes are degenerate.
new_sensitivity_rows <- function(lib, G, near, Y_new) {
  theta <- scaled_theta(lib)[near, , drop = FALSE]
  X <- sweep(theta, 2, theta[1, ])
  X <- X[, apply(X, 2, function(v) diff(range(v)) > 0), drop = FALSE]
  if (ncol(X) == 0L) return(NULL)
  slopes <- function(Y) {
    b <- as.matrix(stats::lm.fit(cbind(1, X), Y)$coefficients)[-1, , drop = FALSE]
    t(matrix(b, ncol(X)))
  }
  S_lib <- slopes(lib_outputs(lib, near))
  S_new <- slopes(Y_new)
  ok <- colSums(!is.finite(S_lib)) == 0L & colSums(!is.finite(S_new)) == 0L
  if (!any(ok)) return(NULL)
  A <- tryCatch(qr.solve(S_lib[, ok, drop = FALSE], qr.Q(qr(G))), error = function(e) NULL)
  if (is.null(A)) NULL else S_new[, ok, drop = FALSE] %*% A
}
