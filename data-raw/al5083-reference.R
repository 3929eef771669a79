# An independent reference posterior for Al-5083 (see data-raw/al5083.R):
# a Gaussian-process emulator of SEPIA's 1,000 runs, a differential-evolution
# Markov chain on it, and importance sampling from the chain's draws (below),
# none of it griddy's code.
#
# Emulator: RobustGaSP::ppgasp() (Gu and Berger 2016; one Matern 5/2
# correlation shared by the 12 outputs, a constant mean and a variance per
# output, a nugget estimated) from theta, scaled to [0, 1] over the design's
# range, to the 12 outputs, each standardised over the runs. Checked first by
# a fit on 900 runs predicting the 100 others (a fixed random hold-out): its
# error, in observation sds, is the reference's own uncertainty.
#
# Likelihood: griddy's (calibrate()'s collapsed update, no correlation, no
# discrepancy) with the emulator's mean in place of a library run:
# y ~ N(m(theta), tau^-1 S^2), S = diag(SEPIA's observation sd), tau ~
# Gamma(1e-9, 1e-9) integrated out, so
#   log p(theta | y) = const - (a + n/2) log(b + C(theta)/2),
#   C(theta) = sum_j ((y_j - m_j(theta)) / s_j)^2,
# uniform prior on the design's box. Variant "emulator variance": the
# emulator's predictive variance v_j(theta) added to each output's noise
# variance (tau^-1 s_j^2 + v_j(theta)), tau sampled as a 12th coordinate
# (log tau, with the same Gamma prior, truncated at tau = 1e4), as SEPIA's emulator-based likelihood
# carries the emulator's uncertainty.
#
# Sampler: differential-evolution Markov chain Monte Carlo (ter Braak 2006)
# on the unit cube: 24 chains started at 24 of the 50 library runs with the
# smallest C; each generation moves one half of the chains by
# gamma (x_a - x_b) + N(0, 1e-4^2), x_a and x_b two chains of the other
# half (held fixed, so each half-step is a Metropolis step with a symmetric
# proposal), gamma = 2.38 / sqrt(2 d), and 1 every tenth generation (jumps
# between modes). The first half of every chain is discarded. R-hat and ESS
# from posterior::summarise_draws(). (Adaptive Metropolis, tried first, had
# 6% acceptance and R-hat up to 1.3 after 60,000 iterations of 8 chains.)
#
# al5083_reference() is called by data-raw/al5083.R; about 30 minutes on a
# shared 2-core machine (load 1-3): the two ppgasp fits 5 and 6 minutes, each
# set of chains 8, the importance sampling 1.
# `emulator_cache`: a file that keeps the two ppgasp fits (read when it
# exists, written when not; "" for neither). `previous`: an earlier result
# of this function with the same settings, whose chains are reused (the
# importance sampling after them has its own seed, so it is the same
# either way).
al5083_reference <- function(design, sim, obs, obs_sd, n_iter = 60000L, chains = 24L,
                             seed = 20261127L, emulator_cache = "", n_is = 500000L,
                             n_round = 50000L, rounds = 4L, previous = NULL) {
  set.seed(seed)
  lo <- vapply(design, min, numeric(1))
  hi <- vapply(design, max, numeric(1))
  unit <- function(theta) sweep(sweep(as.matrix(theta), 2, lo), 2, hi - lo, "/")
  u <- unit(design)
  y_mean <- colMeans(sim)
  y_sd <- apply(sim, 2, stats::sd)
  ys <- sweep(sweep(sim, 2, y_mean), 2, y_sd, "/")
  fit_gp <- function(rows) {
    utils::capture.output(em <- suppressWarnings(RobustGaSP::ppgasp(
      design = u[rows, , drop = FALSE], response = ys[rows, , drop = FALSE],
      nugget.est = TRUE, num_initial_values = 2)))
    em
  }
  # the emulator's mean and variance of the outputs, in their own units
  predict_gp <- function(em, z) {
    p <- RobustGaSP::predict.ppgasp(em, z)
    list(mean = sweep(sweep(p$mean, 2, y_sd, "*"), 2, y_mean, "+"),
         var = sweep(p$sd^2, 2, y_sd^2, "*"))
  }

  # ---- the emulator's error, on 100 runs it did not see --------------------------------
  misfit <- colSums(((t(sim) - obs) / obs_sd)^2)
  hold <- sample(nrow(u), 100L)
  cached <- nzchar(emulator_cache) && file.exists(emulator_cache)
  if (cached) {
    fits <- readRDS(emulator_cache)
  } else {
    started <- proc.time()[["elapsed"]]
    em_check <- fit_gp(-hold)
    check_seconds <- proc.time()[["elapsed"]] - started
    started <- proc.time()[["elapsed"]]
    em <- fit_gp(seq_len(nrow(u)))
    fit_seconds <- proc.time()[["elapsed"]] - started
    fits <- list(em_check = em_check, em = em, hold = hold,
                 seconds = c(check_fit = check_seconds, fit = fit_seconds))
    if (nzchar(emulator_cache)) saveRDS(fits, emulator_cache)
  }
  stopifnot(identical(fits$hold, hold))
  em_check <- fits$em_check
  em <- fits$em
  p <- predict_gp(em_check, u[hold, , drop = FALSE])
  err <- sweep(p$mean - sim[hold, , drop = FALSE], 2, obs_sd, "/")
  z <- (p$mean - sim[hold, , drop = FALSE]) / sqrt(p$var)
  near <- order(misfit[hold])[1:20]
  holdout <- data.frame(
    output = colnames(sim),
    rmse_all = sqrt(colMeans(err^2)),
    rmse_near = sqrt(colMeans(err[near, , drop = FALSE]^2)),
    pred_sd_near = sqrt(colMeans(sweep(p$var[near, , drop = FALSE], 2, obs_sd^2, "/"))),
    coverage95 = colMeans(abs(z) < stats::qnorm(0.975)),
    row.names = NULL)

  # ---- the chains, on the emulator of all 1,000 runs -------------------------------
  set.seed(seed + 1L)  # the same chains whether the emulators were fitted or read
  a <- 1e-9
  b <- 1e-9
  n <- length(obs)
  # with the emulator's variance the likelihood stays finite as tau grows
  # (the noise vanishes, the emulator's variance remains), and the Gamma(1e-9,
  # 1e-9) prior is flat in log tau up to 1e9: tau is kept below 1e4 (a noise
  # sd a hundredth of SEPIA's), which the likelihood never reaches
  log_tau_max <- log(1e4)
  # log posterior of each row of z (unit cube), and for the variance variant
  # of its last column, log tau
  log_post <- function(z, variance) {
    d <- ncol(u)
    theta <- z[, seq_len(d), drop = FALSE]
    out <- rep(-Inf, nrow(z))
    inside <- rowSums(theta < 0 | theta > 1) == 0
    if (!any(inside)) return(out)
    p <- predict_gp(em, theta[inside, , drop = FALSE])
    r2 <- sweep(sweep(p$mean, 2, obs), 2, obs_sd, "/")^2
    if (!variance) {
      out[inside] <- -(a + n / 2) * log(b + rowSums(r2) / 2)
    } else {
      log_tau <- z[inside, d + 1L]
      v <- sweep(p$var, 2, obs_sd^2, "/") + exp(-log_tau)  # in units of s_j^2
      out[inside] <- ifelse(log_tau > log_tau_max, -Inf,
                            -0.5 * rowSums(log(v)) - 0.5 * rowSums(r2 / v) +
                              a * log_tau - b * exp(log_tau))
    }
    out
  }
  starts <- order(misfit)[sample(50L, chains)]
  run_chains <- function(variance) {
    d <- ncol(u) + variance
    cur <- u[starts, , drop = FALSE]
    if (variance) cur <- cbind(cur, log(n / misfit[starts]))
    lp <- log_post(cur, variance)
    keep <- array(NA_real_, c(n_iter / 2, chains, d))
    burn <- n_iter / 2
    accepted <- 0
    halves <- split(seq_len(chains), rep(1:2, length.out = chains))
    gamma <- 2.38 / sqrt(2 * d)
    for (it in seq_len(n_iter)) {
      for (h in 1:2) {
        move <- halves[[h]]
        other <- halves[[3 - h]]
        # differences of two chains of the other half (held fixed): a
        # symmetric proposal; every tenth generation a jump of the whole
        # difference, between modes
        pairs <- t(vapply(move, function(k) sample(other, 2L), integer(2)))
        g <- if (it %% 10L == 0L) 1 else gamma
        prop <- cur[move, , drop = FALSE] +
          g * (cur[pairs[, 1], , drop = FALSE] - cur[pairs[, 2], , drop = FALSE]) +
          matrix(stats::rnorm(length(move) * d, sd = 1e-4), ncol = d)
        lp_prop <- log_post(prop, variance)
        ok <- log(stats::runif(length(move))) < lp_prop - lp[move]
        cur[move[ok], ] <- prop[ok, ]
        lp[move[ok]] <- lp_prop[ok]
        if (it > burn) accepted <- accepted + sum(ok)
      }
      if (it > burn) keep[it - burn, , ] <- cur
    }
    names_d <- c(names(design), if (variance) "log_tau")
    dimnames(keep) <- list(NULL, NULL, names_d)
    draws <- posterior::as_draws_array(keep)
    # back to the parameters' own units
    theta_draws <- posterior::as_draws_df(draws)
    for (j in seq_along(lo)) {
      theta_draws[[names(lo)[j]]] <- lo[j] + (hi[j] - lo[j]) * theta_draws[[names(lo)[j]]]
    }
    summ <- as.data.frame(posterior::summarise_draws(
      posterior::as_draws_array(theta_draws), "mean", "sd",
      ~stats::quantile(.x, c(0.025, 0.975)), "rhat", "ess_bulk", "ess_tail", "mcse_mean",
      ~posterior::mcse_quantile(.x, probs = c(0.025, 0.975))))
    summ[-1] <- lapply(summ[-1], as.numeric)
    draws_df <- as.data.frame(theta_draws)[c(".chain", names_d)]
    list(summary = summ, acceptance = accepted / (chains * burn),
         draws = draws_df[seq(1L, nrow(draws_df), by = 20L), ], starts = starts)
  }
  if (is.null(previous)) {
    started <- proc.time()[["elapsed"]]
    plain <- run_chains(FALSE)
    plain_seconds <- proc.time()[["elapsed"]] - started
    started <- proc.time()[["elapsed"]]
    with_var <- run_chains(TRUE)
    var_seconds <- proc.time()[["elapsed"]] - started
  } else {
    plain <- previous$mcmc
    with_var <- previous$mcmc_emulator_variance
    plain_seconds <- previous$seconds[["mcmc"]]
    var_seconds <- previous$seconds[["mcmc_emulator_variance"]]
  }

  # ---- importance sampling from the chains' draws ----------------------------------
  # The chains need not have mixed for this. Population Monte Carlo (Cappe
  # et al. 2004): a proposal of multivariate t kernels (4 degrees of
  # freedom) centred at 2,000 points drawn from a weighted sample, each with
  # that sample's covariance times 0.5^2, 85%, and the uniform prior, 15% (a
  # defensive mixture, Hesterberg 1995). Round 1 starts from the chains'
  # kept draws; each round proposes n_round points, weighs each by the
  # posterior over the proposal's density (Pareto-smoothed, loo::psis()),
  # and hands its weighted sample to the next. After `rounds` rounds a last
  # proposal draws n_is points, and the estimate is theirs alone, with its
  # Pareto k-hat (below 0.7 the estimate can be trusted) and effective
  # sample size. The kernels' scale 0.5 was chosen from trial runs of 20,000
  # points from the chains' draws at 0.2, 0.4, 0.6 and 0.9 by their k-hat
  # (0.92, 0.73, 0.67, 0.77), not by any comparison with griddy.
  set.seed(seed + 2L)
  started <- proc.time()[["elapsed"]]
  d <- ncol(u)
  df <- 4
  share <- 0.85
  n_kernels <- 2000L
  log_post_batched <- function(z) {
    unlist(lapply(split(seq_len(nrow(z)), ceiling(seq_len(nrow(z)) / 2000)), function(rows) {
      log_post(z[rows, , drop = FALSE], FALSE)
    }))
  }
  propose <- function(points, weights, n) {
    centres <- points[sample(nrow(points), n_kernels, replace = TRUE, prob = weights), ,
                      drop = FALSE]
    mu <- colSums(weights * points)
    root <- chol(0.5^2 * crossprod(sqrt(weights) * sweep(points, 2, mu)))
    n_t <- stats::rbinom(1L, n, share)
    z <- rbind(centres[sample(n_kernels, n_t, replace = TRUE), , drop = FALSE] +
                 matrix(stats::rnorm(n_t * d), ncol = d) %*% root /
                 sqrt(stats::rchisq(n_t, df) / df),
               matrix(stats::runif((n - n_t) * d), ncol = d))
    log_c <- lgamma((df + d) / 2) - lgamma(df / 2) - d / 2 * log(df * pi) -
      sum(log(diag(root)))
    dens <- numeric(n)
    for (k in seq_len(n_kernels)) {
      q <- colSums(backsolve(root, t(z) - centres[k, ], transpose = TRUE)^2)
      dens <- dens + exp(log_c - (df + d) / 2 * log1p(q / df))
    }
    log_w <- log_post_batched(z) - log(share * dens / n_kernels + (1 - share))
    inside <- is.finite(log_w)
    psis <- suppressWarnings(loo::psis(log_w[inside], r_eff = 1))
    w <- numeric(n)
    w[inside] <- as.vector(stats::weights(psis, log = FALSE, normalize = TRUE))
    list(z = z, w = w, pareto_k = unname(psis$diagnostics$pareto_k), ess = 1 / sum(w^2))
  }
  points <- unit(plain$draws[names(design)])
  weights <- rep(1 / nrow(points), nrow(points))
  history <- data.frame(round = integer(), n = integer(), pareto_k = numeric(), ess = numeric())
  for (r in seq_len(rounds + 1L)) {
    n_r <- if (r <= rounds) n_round else n_is
    step <- propose(points, weights, n_r)
    history[r, ] <- list(r, n_r, step$pareto_k, step$ess)
    keep_rows <- step$w > 0
    points <- step$z[keep_rows, , drop = FALSE]
    weights <- step$w[keep_rows]
  }
  z_is <- step$z
  w <- step$w
  theta_is <- sweep(sweep(z_is, 2, hi - lo, "*"), 2, lo, "+")
  weighted_quantile <- function(v, p) {
    o <- order(v)
    cw <- cumsum(w[o])
    vapply(p, function(pp) v[o][which(cw >= pp)[1]], numeric(1))
  }
  importance <- do.call(rbind, lapply(seq_len(d), function(j) {
    v <- theta_is[, j]
    m <- sum(w * v)
    q <- weighted_quantile(v, c(0.025, 0.975))
    data.frame(variable = names(design)[j], mean = m, sd = sqrt(sum(w * (v - m)^2)),
               `2.5%` = q[1], `97.5%` = q[2], check.names = FALSE)
  }))
  importance <- list(summary = importance, pareto_k = step$pareto_k, ess = step$ess,
                     n = n_is, rounds = history,
                     seconds = proc.time()[["elapsed"]] - started)

  # the emulator at the reference's posterior mean: how far from the data
  at_mean <- predict_gp(em, unit(matrix(plain$summary$mean[seq_along(lo)], 1)))
  list(holdout = holdout, emulator = list(range = em@beta_hat, nugget = em@nugget,
                                          kernel = em@kernel_type),
       mcmc = plain, mcmc_emulator_variance = with_var, importance = importance,
       residual_at_mean = drop((obs - at_mean$mean) / obs_sd),
       emulator_sd_at_mean = drop(sqrt(at_mean$var) / obs_sd),
       settings = list(n_iter = n_iter, chains = chains, seed = seed, hold = hold),
       seconds = c(fits$seconds, mcmc = plain_seconds, mcmc_emulator_variance = var_seconds))
}
