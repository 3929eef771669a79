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
  data.frame(ess_bulk = if (is.null(ess_bulk)) quiet_cap(posterior::ess_bulk(m)) else ess_bulk,
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
  r <- posterior::rhat(m)
  if (is.na(r)) Inf else r
}

# What calibrate()'s convergence check needs of a fit's draws, computed once
# by new_griddy_fit() and kept for summary(): the R-hat of every sampled
# parameter (NA for a constant one), the bulk ESS of the run's exact log
# probability and of each theta column (NA for one that does not move), and
# the effective number of draws of the run index (run_effective_draws()).
# The tail ESS and MCSE only summary() reports, so it computes them.
fit_diagnostics <- function(fit) {
  rhat <- vapply(parameter_draws(fit), function(v) {
    chain_rhat(chain_matrix(v, fit$draws$chain))
  }, numeric(1))
  ess <- run_ess(fit, exact_margins(fit)$run)
  list(rhat = rhat, ess_bulk = ess, effective_draws = run_effective_draws(nrow(fit$draws), ess))
}

# A fit's diagnostics: stored, or computed for a fit saved before they were.
stored_diagnostics <- function(fit) {
  if (!is.null(fit$diagnostics)) return(fit$diagnostics)
  fit_diagnostics(fit)
}

# The bulk ESS of the run's exact log probability (`log_p`) and of each theta
# column over the draws; NA for one that does not move.
run_ess <- function(fit, exact_run) {
  cols <- c(list(log_p = log(exact_run[fit$draws$run])),
            lapply(lib_theta(fit$library), `[`, fit$draws$run))
  vapply(cols, function(v) {
    m <- chain_matrix(v, fit$draws$chain)
    if (all(m == m[1]) || !all(is.finite(m))) NA_real_ else quiet_cap(posterior::ess_bulk(m))
  }, numeric(1))
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
