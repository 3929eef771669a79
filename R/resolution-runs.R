# Is a scattered library in four or more parameters resolved? The
# per-parameter test of resolution.R (10 effective values per
# marginal) counts runs, not values, when every run has its own value of
# every parameter: 11 effective runs gave 11 parameters 10 effective values
# each (issue 24, Al-5083). From four parameters (proposal_min_parameters,
# where refine() also stops using boxes) the posterior over runs is judged
# as what it is, a self-normalised importance sample of the posterior over
# theta (weights: prior over design density, times the likelihood):
#
# * effective runs (Kish, 1 / sum p_i^2) at least max(100, 20 p). Why 20
#   per parameter: the weighted runs must span all p directions of the
#   posterior, with a p x p covariance estimated from them (refine()'s next
#   proposal is fitted to it); with n effective points the extreme
#   eigenvalues of a sample covariance are off by factors of about
#   (1 +- sqrt(p / n))^2 (Marchenko-Pastur), within a factor of 1.6 at
#   n = 20 p. The floor of 100 keeps a 95% interval's bounds, whose Monte
#   Carlo sd is about 0.69 / sqrt(n) of a Gaussian interval's width, within
#   a fifteenth of it. (The notes' suggestion, many-parameters.md section 8;
#   a judgement, checked by bench/many-parameters.R, not a citation.)
# * the Pareto-smoothed importance sampling k-hat of the log weights below
#   min(1 - 1 / log10(S), 0.7) over S runs (Vehtari et al. 2024, JMLR
#   25(72)): above it the weights' tail is too heavy for the posterior
#   mean, let alone a 95% interval, to be estimated (a few runs carry it).
#   k-hat fits the largest 3 sqrt(S) weights, so it also fails while the
#   posterior rests on fewer runs than that;
# * (in refine(), against the previous round) intervals that moved by at
#   most a fifth of their width: is_resolved().

run_resolution_per_parameter <- 20
run_resolution_floor <- 100

effective_runs_needed <- function(p) max(run_resolution_floor, run_resolution_per_parameter * p)

# The run-level test applies from four varying parameters, and in fewer to
# a library whose runs refine() drew from proposals (scattered draws: a
# marginal's effective values are its effective runs there too).
runs_test_applies <- function(n_varying, scattered = FALSE) {
  scattered || n_varying >= proposal_min_parameters
}

# A search round (refine-modes.R) that seeded one maximum is a Latin
# hypercube over the range plus a box around it: below four parameters,
# with boxes after it, the library is judged as boxes' (from four, every
# round is a proposal's).
has_proposal_rounds <- function(library) {
  rounds <- lib_rounds(library)
  if (length(rounds) == 0L) return(FALSE)
  many <- uses_proposal(library)
  any(vapply(rounds, function(r) {
    !is.null(r$proposal) && (many || proposals_follow(r$proposal))
  }, logical(1)))
}

# Pareto k-hat of the posterior weights over runs (the log weights are
# log p_i; runs whose probability underflows to 0 enter far below the
# others, outside the tail). NA with fewer than 20 runs.
weights_pareto_k <- function(p) {
  if (length(p) < 20L) return(NA_real_)
  lw <- log(p)
  finite <- is.finite(lw)
  if (!any(finite)) return(NA_real_)
  lw[!finite] <- min(lw[finite]) - 100
  k <- suppressWarnings(loo::pareto_k_values(loo::psis(lw, r_eff = 1)))
  unname(k[1])
}

pareto_k_threshold <- function(S) min(1 - 1 / log10(S), 0.7)

# The run-level test: list(effective_runs, needed, pareto_k, k_threshold,
# resolved); `applies` FALSE (and resolved TRUE) below four parameters.
run_resolution <- function(p, n_varying, scattered = FALSE) {
  ess <- effective_count(p)
  applies <- runs_test_applies(n_varying, scattered)
  k <- if (applies) weights_pareto_k(p) else NA_real_
  needed <- effective_runs_needed(n_varying)
  threshold <- pareto_k_threshold(length(p))
  list(effective_runs = ess, needed = needed, parameters = n_varying, pareto_k = k,
       k_threshold = threshold, applies = applies,
       resolved = !applies || (ess >= needed && !is.na(k) && k < threshold))
}

# Why the run-level test fails, in words (NULL when it passes).
run_resolution_reason <- function(runs) {
  if (is.null(runs) || runs$resolved) return(NULL)
  paste0(format(runs$effective_runs, digits = 3), " effective runs (", runs$needed,
         " needed for ", runs$parameters, " parameters)",
         if (!is.na(runs$pareto_k) && runs$pareto_k >= runs$k_threshold) {
           paste0(" and Pareto k-hat ", format(runs$pareto_k, digits = 2), " (above ",
                  format(runs$k_threshold, digits = 2), ": a few runs carry the posterior)")
         })
}
