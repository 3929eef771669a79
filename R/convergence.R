# Convergence diagnostics: rank-normalised ESS, R-hat and MCSE per parameter
# (posterior package; Vehtari et al. 2021), the Monte Carlo reference for the
# total-variation distance between the sampled and the exact posterior over
# runs, and calibrate()'s warning when either says the chains have not mixed.

# Above this R-hat (Vehtari et al. 2021) a parameter's chains disagree.
rhat_threshold <- 1.01
# A total-variation distance counts as beyond Monte Carlo error when it is more
# than `tv_ratio_threshold` times the reference and above `tv_min_threshold`.
tv_ratio_threshold <- 3
tv_min_threshold <- 0.05

# Draws of one parameter as a matrix, iterations x chains (every chain keeps
# as many draws).
chain_matrix <- function(v, chain) {
  do.call(cbind, split(v, chain))
}

# Rank-normalised diagnostics of one parameter from a matrix of draws,
# iterations x chains: bulk and tail ESS, R-hat (over split chains, so one
# chain has one too) and the Monte Carlo standard error of the mean. All NA
# for a parameter whose kept draws are all one value. `rhat` and `ess_bulk`,
# when given, are those already computed (a fit's stored ones).
chain_diagnostics <- function(m, rhat = NULL, ess_bulk = NULL) {
  if (all(m == m[1])) {
    return(data.frame(ess_bulk = NA_real_, ess_tail = NA_real_, rhat = NA_real_,
                      mcse = NA_real_))
  }
  data.frame(ess_bulk = if (is.null(ess_bulk)) rank_ess_bulk(m) else ess_bulk,
             ess_tail = quiet_cap(posterior::ess_tail(m)),
             rhat = if (is.null(rhat)) chain_rhat(m) else rhat,
             mcse = quiet_cap(posterior::mcse_mean(m)))
}

# posterior caps an ESS at n log10(n) (antithetic chains) and says so each
# time; the cap is documented in ?summary.griddy_fit instead.
quiet_cap <- function(expr) {
  withCallingHandlers(expr, warning = function(w) {
    if (grepl("ESS has been capped", conditionMessage(w), fixed = TRUE)) {
      invokeRestart("muffleWarning")
    }
  })
}

# posterior::rhat(), but Inf (not NA) when the draws differ although every
# chain half sits on one value: chains stuck on different values.
chain_rhat <- function(m) {
  if (all(m == m[1])) return(NA_real_)
  r <- rank_rhat(m)
  if (is.na(r)) Inf else r
}

# ---- rank-normalised R-hat and bulk ESS -------------------------------------
# posterior::rhat() and posterior::ess_bulk() (version 1.4.0; Vehtari et al.
# 2021) computed as they do, step for step, without their per-call checks
# and conversions: on a fit's 20,000 draws those took 60-75% of calibrate()
# (bench/calibrate-overhead.R). The ranks come from one radix sort. The
# results agree with posterior's to rounding (test-convergence.R); draws
# with a value that is not finite go to posterior itself.

# The halves of each chain (columns of m), as separate chains; an odd
# chain's middle draw is left out (posterior's .split_chains()).
split_halves <- function(m) {
  n <- nrow(m)
  if (n == 1L) return(m)
  half <- n / 2
  cbind(m[seq_len(floor(half)), , drop = FALSE], m[ceiling(half + 1):n, , drop = FALSE])
}

# Normal scores of the ranks of all draws together, ties averaged
# (posterior's z_scale(): rank(ties.method = "average"), then qnorm of
# (r - 3/8) / (S + 1/4)), in the shape of m. `discrete`: the draws take few
# values (a theta column, a function of the run): the ranks are then
# counted per distinct value, and qnorm() is evaluated once per value (the
# same numbers, in a third of the time on a fit's 16,000 draws).
normal_scores <- function(m, discrete = FALSE) {
  x <- as.vector(m)
  n <- length(x)
  if (discrete) {
    u <- unique(x)
    if (4L * length(u) <= n) {
      u <- sort(u)
      code <- match(x, u)
      ends <- cumsum(tabulate(code, length(u)))
      starts <- c(1L, ends[-length(ends)] + 1L)
      z <- stats::qnorm(((starts + ends) / 2 - 3 / 8) / (n - 2 * 3 / 8 + 1))
      return(matrix(z[code], nrow(m)))
    }
  }
  o <- order(x, method = "radix")
  xs <- x[o]
  ends <- c(which(xs[-1L] != xs[-n]), n)
  starts <- c(1L, ends[-length(ends)] + 1L)
  z <- numeric(n)
  if (length(ends) == n) {
    # no ties: the draw at sorted position i has rank i
    z[o] <- rank_scores(n)
    return(matrix(z, nrow(m)))
  }
  r <- numeric(n)
  r[o] <- rep((starts + ends) / 2, ends - starts + 1L)
  # a whole rank's score is the same number for every parameter and fit
  # with n draws (rank_scores()); a tie's half rank is computed
  whole <- r == floor(r)
  z[whole] <- rank_scores(n)[r[whole]]
  z[!whole] <- stats::qnorm((r[!whole] - 3 / 8) / (n - 2 * 3 / 8 + 1))
  matrix(z, nrow(m))
}

# The normal scores qnorm((r - 3/8) / (n + 1/4)) of the ranks r = 1..n,
# computed once for the last n asked (a fit's parameters all have n draws).
rank_scores <- function(n) {
  if (!identical(score_cache$n, n)) {
    score_cache$z <- stats::qnorm((seq_len(n) - 3 / 8) / (n - 2 * 3 / 8 + 1))
    score_cache$n <- n
  }
  score_cache$z
}
score_cache <- new.env(parent = emptyenv())

# posterior's should_return_NA() for finite draws: all one value.
is_flat <- function(m) abs(max(m) - min(m)) < .Machine$double.eps

# R-hat of chains (columns of m) as they are (posterior's .rhat()).
basic_rhat <- function(m) {
  if (is_flat(m)) return(NA_real_)
  n <- nrow(m)
  means <- .colMeans(m, n, ncol(m))
  within <- mean(.colSums((m - rep(means, each = n))^2, n, ncol(m)) / (n - 1))
  between <- n * stats::var(means)
  sqrt((between / within + n - 1) / n)
}

# posterior::rhat(m): the larger of the bulk and the tail (folded about the
# median) R-hat, each over rank-normalised split chains; NA when either is.
# `bulk`: the bulk's normal scores, when already computed (bulk_scores()).
rank_rhat <- function(m, discrete = FALSE, bulk = NULL) {
  if (!all(is.finite(m))) return(posterior::rhat(m))
  if (is.null(bulk)) bulk <- bulk_scores(m, discrete)
  tail <- basic_rhat(normal_scores(split_halves(abs(m - stats::median(m))), discrete))
  max(basic_rhat(bulk), tail)
}

# The normal scores of the split chains, which the bulk R-hat and the bulk
# ESS both read.
bulk_scores <- function(m, discrete = FALSE) normal_scores(split_halves(m), discrete)

# posterior::ess_bulk(m), with posterior's cap at n log10(n) (silent here,
# as quiet_cap() makes it).
rank_ess_bulk <- function(m, discrete = FALSE, bulk = NULL) {
  if (!all(is.finite(m))) return(quiet_cap(posterior::ess_bulk(m)))
  basic_ess(if (is.null(bulk)) bulk_scores(m, discrete) else bulk)
}

# The autocovariances of one chain by FFT (posterior's autocovariance()).
chain_autocovariance <- function(x) drop(chain_autocovariances(matrix(x)))

# chain_autocovariance() of every column of m at once (one mvfft() pair:
# the same transform, column by column, as fft()).
chain_autocovariances <- function(m) {
  n <- nrow(m)
  v <- vapply(seq_len(ncol(m)), function(k) stats::var(m[, k]), numeric(1))
  centred <- m - rep(vapply(seq_len(ncol(m)), function(k) mean(m[, k]), numeric(1)), each = n)
  padded <- rbind(centred, matrix(0, 2 * stats::nextn(n) - n, ncol(m)))
  ac <- Re(stats::mvfft(abs(stats::mvfft(padded))^2, inverse = TRUE)[seq_len(n), , drop = FALSE])
  out <- ac / rep(ac[1, ], each = n) * rep(v, each = n) * (n - 1) / n
  out[, v == 0] <- 0
  out
}

# The ESS of chains (columns of m) from Geyer's initial monotone sequence of
# autocorrelations (posterior's .ess(), step for step).
basic_ess <- function(m) {
  n_chains <- ncol(m)
  n <- nrow(m)
  if (n < 3L || is_flat(m)) return(NA_real_)
  acov <- .rowMeans(chain_autocovariances(m), n, n_chains)
  mean_var <- acov[1] * n / (n - 1)
  var_plus <- mean_var * (n - 1) / n
  if (n_chains > 1L) var_plus <- var_plus + stats::var(.colMeans(m, n, n_chains))
  rho <- rep.int(0, n)
  t <- 0
  even <- 1
  rho[1] <- even
  odd <- 1 - (mean_var - acov[2]) / var_plus
  rho[2] <- odd
  while (t < n - 5 && !is.nan(even + odd) && (even + odd > 0)) {
    t <- t + 2
    even <- 1 - (mean_var - acov[t + 1]) / var_plus
    odd <- 1 - (mean_var - acov[t + 2]) / var_plus
    if (even + odd >= 0) {
      rho[t + 1] <- even
      rho[t + 2] <- odd
    }
  }
  max_t <- t
  if (even > 0) rho[max_t + 1] <- even
  t <- 0
  while (t <= max_t - 4) {
    t <- t + 2
    if (rho[t + 1] + rho[t + 2] > rho[t - 1] + rho[t]) {
      rho[t + 1] <- (rho[t - 1] + rho[t]) / 2
      rho[t + 2] <- rho[t + 1]
    }
  }
  total <- n_chains * n
  # posterior sums rho[1:max_t], which is rho[1] when max_t is 0
  tau <- -1 + 2 * sum(rho[if (max_t == 0) 1L else seq_len(max_t)]) + rho[max_t + 1]
  total / max(tau, 1 / log10(total))
}

# What calibrate()'s convergence check needs of a fit's draws, computed once
# by new_griddy_fit() and kept for summary(): the R-hat of every sampled
# parameter (NA for a constant one), the bulk ESS of the run's exact log
# probability and of each theta column (NA for one that does not move), and
# the effective number of draws of the run index (run_effective_draws()).
# The tail ESS and MCSE only summary() reports, so it computes them. A
# theta column's bulk normal scores serve its R-hat and its ESS both.
fit_diagnostics <- function(fit) {
  as_chains <- chain_shaper(fit$draws$chain)
  params <- sampled_columns(fit)
  # theta columns and correlation parameters take few values, the
  # precisions any
  discrete <- !names(params) %in% tau_columns(fit)
  bulk <- list()
  rhat <- vapply(seq_along(params), function(k) {
    m <- as_chains(params[[k]])
    if (all(m == m[1])) return(NA_real_)
    if (discrete[k] && all(is.finite(m))) {
      bulk[[names(params)[k]]] <<- bulk_scores(m, TRUE)
    }
    r <- rank_rhat(m, discrete[k], bulk[[names(params)[k]]])
    if (is.na(r)) Inf else r
  }, numeric(1))
  names(rhat) <- names(params)
  ess <- run_ess(fit, exact_margins(fit)$run, as_chains, bulk)
  list(rhat = rhat, ess_bulk = ess, effective_draws = run_effective_draws(nrow(fit$draws), ess))
}

# The columns of parameter_draws(fit) (theta, the precisions, the sampled
# correlation parameters), as a list, without building the draws' data.frame.
sampled_columns <- function(fit) {
  d <- fit$draws
  theta <- lib_theta(fit$library)
  tau <- tau_columns(fit)
  grid <- fit$grid
  fixed <- names(grid)[vapply(grid, function(v) length(unique(v)) == 1L, logical(1))]
  keep <- setdiff(c(names(theta), tau, names(grid)),
                  c("chain", "iteration", "run", fixed, "delta_length_x", "delta_length_t"))
  # as.data.frame(fit)'s columns: theta, then the precisions, then the grid
  lapply(stats::setNames(keep, keep), function(v) {
    if (v %in% names(theta)) return(theta[[v]][d$run])
    if (v %in% tau) return(d[[v]])
    grid[[v]][d$grid_point]
  })
}

# A function that shapes a draws column as chain_matrix(v, chain) does; a
# plain matrix() when the draws are in chain order with every chain as
# long (as new_griddy_fit() stores them).
chain_shaper <- function(chain) {
  counts <- tabulate(chain)
  if (!is.unsorted(chain) && length(counts) > 0L && all(counts == counts[1]) &&
        identical(as.numeric(sort(unique(chain))), as.numeric(seq_along(counts)))) {
    return(function(v) matrix(v, counts[1]))
  }
  function(v) chain_matrix(v, chain)
}

# A fit's diagnostics: stored, or computed for a fit saved before they were.
stored_diagnostics <- function(fit) {
  if (!is.null(fit$diagnostics)) return(fit$diagnostics)
  fit_diagnostics(fit)
}

# The bulk ESS of the run's exact log probability (`log_p`) and of each theta
# column over the draws; NA for one that does not move. `as_chains` shapes a
# column as chains (chain_shaper()); `bulk` holds normal scores already
# computed, by column name.
run_ess <- function(fit, exact_run, as_chains = chain_shaper(fit$draws$chain),
                    bulk = list()) {
  cols <- c(list(log_p = log(exact_run[fit$draws$run])),
            lapply(lib_theta(fit$library), `[`, fit$draws$run))
  known <- c(list(NULL), lapply(names(cols)[-1], function(j) bulk[[j]]))
  out <- vapply(seq_along(cols), function(k) {
    m <- as_chains(cols[[k]])
    if (all(m == m[1]) || !all(is.finite(m))) NA_real_ else rank_ess_bulk(m, TRUE, known[[k]])
  }, numeric(1))
  stats::setNames(out, names(cols))
}

# The effective number of draws of the run index: the smallest of run_ess(),
# at most the number of draws `n`. When nothing moves (every draw on one
# run) the draws are taken as independent, so a chain stuck off the
# posterior's mass is far beyond the reference.
run_effective_draws <- function(n, ess) {
  if (all(is.na(ess))) return(n)
  min(n, ess, na.rm = TRUE)
}

# The runs the draws `run` visit and their frequencies (a library's runs
# are many, the draws' few: no vector as long as the library).
sampled_frequencies <- function(run) {
  runs <- unique(run)
  list(run = runs, freq = tabulate(match(run, runs), length(runs)) / length(run))
}

# The total-variation distance between the frequencies of the draws `run`
# and the exact posterior over runs, over the runs that either gives mass
# (elsewhere both are 0).
run_tv_distance <- function(run, exact_run) {
  sampled <- sampled_frequencies(run)
  runs <- union(sampled$run, which(exact_run > 0))
  freq <- numeric(length(runs))
  freq[seq_along(sampled$run)] <- sampled$freq
  sum(abs(freq - exact_run[runs])) / 2
}

# Expected total-variation distance between p and the empirical frequencies
# of m independent draws from p: (1/2) sum_i E|X_i/m - p_i| with
# X_i ~ Binomial(m, p_i), whose mean absolute deviation is De Moivre's
# E|X - mp| = 2 (k + 1) (1 - p) P(X = k + 1), k = floor(m p). Exact (no
# normal approximation, which overstates it for runs with m p_i < 1), and
# about (1/2) sum_i sqrt(2 p_i (1 - p_i) / (pi m)) for large m p_i.
expected_tv <- function(p, m) {
  m <- max(1, round(m))
  p <- p[p > 0]
  k <- floor(m * p)
  sum((k + 1) * (1 - p) * stats::dbinom(k + 1, m, p)) / m
}

# TRUE when the sampled posterior over runs is further from the exact one
# than Monte Carlo error explains (see tv_ratio_threshold).
tv_beyond_reference <- function(tv, reference) {
  is.finite(tv) && is.finite(reference) && tv > tv_min_threshold &&
    tv > tv_ratio_threshold * reference
}

# What the convergence checks find: parameters with R-hat above the threshold
# (named R-hat values) and whether the total-variation distance is beyond its
# Monte Carlo reference.
convergence_problems <- function(rhat, tv, reference) {
  list(rhat = rhat[!is.na(rhat) & rhat > rhat_threshold],
       tv = tv_beyond_reference(tv, reference))
}

# One sentence per problem, for calibrate()'s warning and summary()'s notes.
format_convergence <- function(problems, tv, reference) {
  c(if (length(problems$rhat) > 0L) {
      paste0("R-hat above ", rhat_threshold, " for ",
             paste0(names(problems$rhat), " (", trimws(formatC(problems$rhat, digits = 3, format = "f")),
                    ")",
                    collapse = ", "),
             ": the chains (each split in halves) disagree, so they have not mixed. Run ",
             "longer chains, or use ",
             "`update = \"collapsed\"` if the fit uses the thesis's update.")
    },
    if (problems$tv) {
      paste0("The draws are ", format(tv, digits = 2), " in total-variation distance from ",
             "the exact posterior over runs, beyond Monte Carlo error alone (",
             format(reference, digits = 2), "): the chains have not explored the ",
             "posterior; compare with posterior_exact().")
    })
}

# calibrate()'s warning (class griddy_warning_convergence), from the fit's
# stored margins and diagnostics.
warn_convergence <- function(fit) {
  exact_run <- exact_margins(fit)$run
  diagnostics <- stored_diagnostics(fit)
  tv <- run_tv_distance(fit$draws$run, exact_run)
  reference <- expected_tv(exact_run, diagnostics$effective_draws)
  problems <- convergence_problems(diagnostics$rhat, tv, reference)
  lines <- format_convergence(problems, tv, reference)
  if (length(lines) == 0L) return(invisible(NULL))
  griddy_warn("The chains may not have converged. ", paste(lines, collapse = " "),
              class = "convergence")
}
