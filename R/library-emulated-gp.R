# The emulator of an emulated library (library-emulated.R): one parallel
# partial Gaussian process, RobustGaSP::ppgasp() (Gu & Berger 2016), fitted
# once to the design runs, in one of two forms:
#
#   "theta"  the design is complete at the wanted settings (every theta run
#            at every one of them): theta -> all n_x * n_t outputs of the
#            library's layout, one GP over the distinct thetas (the form of
#            the thesis's ch. 3 surrogate, 343 runs x 54 outputs);
#   "joint"  any other design: (x, theta) -> the n_t outputs of one run, one
#            GP over every run, so runs at any x setting train it and the
#            wanted settings need not have been run at all.
#
# Inputs are scaled to [0, 1] over the design (and, for x, the wanted
# settings), inputs constant there dropped; outputs constant over the runs
# are not modelled (ppgasp refuses them) but returned as they are. Chosen
# over a principal-component basis (GPMSA/SEPIA) by bench/design-emulation.R
# (bench/results/design-emulation.md).

# design: list(theta = N x p matrix, x = N x d matrix (d may be 0), y = N x
# n_t matrix), settings: K x d matrix of the wanted settings (K = 1, d = 0
# without control variables).
design_gp <- function(design, settings) {
  require_package("RobustGaSP", "to emulate a library from a design")
  n_t <- ncol(design$y)
  grouped <- complete_design(design, settings)
  if (!is.null(grouped)) {
    inputs <- grouped$theta
    outputs <- grouped$y
    mode <- "theta"
  } else {
    inputs <- cbind(design$x, design$theta)
    outputs <- design$y
    mode <- "joint"
  }
  # x is scaled over the runs' and the wanted settings together
  ranges <- apply(inputs, 2, range)
  if (mode == "joint" && ncol(settings) > 0L) {
    x_cols <- seq_len(ncol(settings))
    ranges[, x_cols] <- apply(rbind(design$x, settings), 2, range)
  }
  lower <- ranges[1, ]
  span <- ranges[2, ] - lower
  used <- which(span > 0)
  gp <- list(mode = mode, n_x = nrow(settings), n_t = n_t, d_x = ncol(settings),
             lower = lower, span = span, used = used, settings = settings,
             theta_names = colnames(design$theta))
  z <- gp_scale(gp, inputs)
  if (nrow(z) < length(used) + 3L) {
    griddy_abort("Emulating a library needs at least ", length(used) + 3L, " design runs ",
                 "for ", length(used), " varying input(s); the design has ", nrow(z), ".")
  }
  if (nrow(z) > design_gp_max_points) {
    griddy_abort("The design has ", nrow(z), " ", if (mode == "joint") "(x, theta) runs" else
                   "theta values", ", more than the ", design_gp_max_points, " one Gaussian ",
                 "process is fitted to here; give a design complete at the wanted settings ",
                 "(every theta at every setting) or fewer runs.", class = "input")
  }
  gp$vary <- apply(outputs, 2, function(v) max(v) - min(v) > 1e-12 * max(abs(v), 1e-300))
  gp$constant <- outputs[1, ]
  gp$fit <- if (any(gp$vary)) gp_fit(z, outputs[, gp$vary, drop = FALSE])
  loo <- ppgasp_loo(gp$fit, gp$vary, nrow(outputs))
  gp$loo <- loo$residuals
  gp$loo_var <- loo$var
  gp$loo_theta <- if (mode == "theta") grouped$theta else design$theta
  gp
}

# ppgasp's cost grows with the cube of its runs: past this many the fit
# takes minutes.
design_gp_max_points <- 3000L

# The design as one row per distinct theta holding its outputs at every
# wanted setting in turn (the library's layout), or NULL when some theta
# lacks a wanted setting. Runs at other settings are left out.
complete_design <- function(design, settings) {
  if (ncol(settings) == 0L) {
    if (anyDuplicated(design$theta)) return(NULL)
    return(list(theta = design$theta, y = design$y))
  }
  setting <- match_rows(design$x, settings)
  run <- row_groups(design$theta)
  keep <- !is.na(setting)
  pair <- paste(run[keep], setting[keep])
  if (anyDuplicated(pair)) return(NULL)
  thetas <- unique(run[keep])
  if (length(thetas) < 2L || sum(keep) != length(thetas) * nrow(settings)) return(NULL)
  n_t <- ncol(design$y)
  rows <- match(thetas, run[keep])
  y <- matrix(NA_real_, length(thetas), nrow(settings) * n_t)
  r <- match(run[keep], thetas)
  cols <- outer((setting[keep] - 1L) * n_t, seq_len(n_t), "+")
  y[cbind(rep(r, n_t), as.vector(cols))] <- as.vector(design$y[keep, , drop = FALSE])
  list(theta = design$theta[which(keep)[rows], , drop = FALSE], y = y)
}

gp_scale <- function(gp, inputs) {
  z <- (inputs - rep(gp$lower, each = nrow(inputs))) / rep(gp$span, each = nrow(inputs))
  z[, gp$used, drop = FALSE]
}

# Predictions at the rows of theta (a matrix in the design's columns) at
# every wanted setting: list(mean = n x (n_x n_t), the library's layout; var
# = n x n_x, the predictive variance relative to an output's GP variance,
# shared by the outputs). Chunks of rows go to the future plan's workers
# (griddy_map()).
design_gp_predict <- function(gp, theta, chunk = 10000L) {
  chunks <- split(seq_len(nrow(theta)), (seq_len(nrow(theta)) - 1L) %/% chunk)
  one <- function(rows, gp, theta) design_gp_predict_chunk(gp, theta[rows, , drop = FALSE])
  environment(one) <- asNamespace("griddy")
  out <- griddy_map(chunks, one, gp = gp, theta = theta)
  list(mean = do.call(rbind, lapply(out, `[[`, "mean")),
       var = do.call(rbind, lapply(out, `[[`, "var")))
}

design_gp_predict_chunk <- function(gp, theta) {
  n <- nrow(theta)
  if (gp$mode == "theta") {
    pred <- gp_mean_var_at(gp, gp_scale(gp, theta))
    return(list(mean = pred$mean, var = matrix(pred$var, n, 1L)))
  }
  mean <- matrix(0, n, gp$n_x * gp$n_t)
  var <- matrix(0, n, gp$n_x)
  for (k in seq_len(gp$n_x)) {
    inputs <- cbind(gp$settings[rep(k, n), , drop = FALSE], theta)
    pred <- gp_mean_var_at(gp, gp_scale(gp, inputs))
    mean[, (k - 1L) * gp$n_t + seq_len(gp$n_t)] <- pred$mean
    var[, k] <- pred$var
  }
  list(mean = mean, var = var)
}

# Mean and relative variance at scaled inputs z; a variance ppgasp cannot give
# (near-singular runs) counts as the largest given, at least 1.
gp_mean_var_at <- function(gp, z) {
  pred <- ppgasp_mean_var(gp$fit, gp$vary, gp$constant, z)
  v <- pred$var
  v[!is.finite(v)] <- max(c(v[is.finite(v)], 1))
  list(mean = pred$mean, var = v)
}

# The GP's correlation between the wanted settings (joint form): its Matern
# 5/2 product kernel over the x inputs at the fitted range parameters (theta
# held fixed, so the theta part is 1). How much a misprediction at one theta
# is shared by the settings.
design_gp_setting_cor <- function(gp) {
  if (gp$mode == "theta" || gp$n_x == 1L) return(diag(gp$n_x))
  x_used <- which(gp$used <= gp$d_x)
  if (length(x_used) == 0L || is.null(gp$fit)) return(matrix(1, gp$n_x, gp$n_x))
  z <- gp_scale(gp, cbind(gp$settings, matrix(0, gp$n_x, length(gp$lower) - gp$d_x)))
  K <- matrix(1, gp$n_x, gp$n_x)
  for (j in x_used) {
    d <- abs(outer(z[, j], z[, j], "-")) * gp$fit@beta_hat[j]
    K <- K * (1 + sqrt(5) * d + 5 / 3 * d^2) * exp(-sqrt(5) * d)
  }
  K
}
