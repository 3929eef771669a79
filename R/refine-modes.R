# Every mode from any start (issue 35, item 2). A coarse base library shows
# the posterior at its own resolution: on the aliased oscillator's 64-run
# grid the runs nearest the two modes lie hundreds of log units apart, a
# proposal fitted to the tempered posterior puts one component on the
# better, and the rounds after zoom in on it (16 of 20 fits ended on one
# mode, 14 unwarned, three of them only on the alias). Two remedies:
#
# * A search round. The first round of a refinement whose base posterior
#   rests on few runs draws half its runs uniformly over the library's range
#   (a Latin hypercube, so a mode the base library only brushes gets runs
#   near it) and half around each local maximum of the base posterior over
#   the runs' neighbourhood graph, one t component per maximum as wide as
#   the library's spacing there (a maximum between coarse runs lies within
#   one step of its best run). The rounds after fit their proposal, or box,
#   to the library this round has grown.
# * A warning. When the base library's posterior (tempered as the proposal's
#   is, so that a coarse library shows its shape) has separated modes each
#   holding at least `mode_lost_share`, and the refined posterior holds under
#   mode_min_mass near one of them, refine() says so, naming where the mode
#   was and its share, with or without a simulator.

# ---- the search round --------------------------------------------------------

# The share of the search round drawn uniformly over the range, and the most
# maxima it seeds (the best first).
mode_search_uniform <- 0.5
mode_search_max_seeds <- 8L

# A maximum is seeded when its tempered weight is at least this share of the
# best run's (the tempering of fit_proposal(), so the window widens as the
# library coarsens).
mode_search_min_ratio <- 0.01

# The search round's proposal (refine-proposal.R's format, marked `search`),
# or NULL when the rounds have begun or the base posterior already rests on
# as many effective runs as a proposal is fitted to (the library then shows
# its modes itself).
mode_search_proposal <- function(state) {
  problem <- state$problem
  library <- problem$library
  if (length(lib_rounds(library)) > 0L) return(NULL)
  range0 <- library_box(library)
  varies <- range0[2, ] > range0[1, ]
  q <- sum(varies)
  if (q == 0L || effective_count(state$p) >= proposal_ess(q)) return(NULL)
  theta <- as.matrix(lib_theta(library))
  u <- unit_coordinates(theta, range0, varies)
  ll <- proposal_log_lik(problem)
  tempered <- tempered_weights(ll, problem$log_prior_run, proposal_ess(q))
  seeds <- local_maxima(u, log(tempered$w), 2L * q, log(mode_search_min_ratio),
                        mode_search_max_seeds)
  components <- lapply(seeds, function(i) {
    spacing <- local_spacing(theta, i, range0)[varies] / (range0[2, varies] - range0[1, varies])
    list(weight = 1 / length(seeds), centre = u[i, ], chol = diag(spacing / 2, q))
  })
  proposal <- list(range = range0, varies = varies, components = components,
                   df = proposal_df, defensive = mode_search_uniform, inside = 1,
                   beta = tempered$beta, search = TRUE)
  proposal$inside <- withr::with_preserve_seed(mixture_mass_inside(proposal))
  proposal
}

# The runs (rows of u) whose log weight `lw` is at least that of each of
# their k nearest neighbours and within `window` of the best, the best
# first, at most `max_seeds`. Only the best runs are candidates, so the
# distances are max_seeds-sized blocks, not n x n.
local_maxima <- function(u, lw, k, window, max_seeds) {
  top <- max(lw)
  candidates <- order(lw, decreasing = TRUE)
  candidates <- candidates[lw[candidates] >= top + window]
  found <- integer()
  for (block in split(candidates, ceiling(seq_along(candidates) / 50L))) {
    for (i in block) {
      d2 <- colSums((t(u) - u[i, ])^2)
      d2[i] <- Inf
      near <- order(d2)[seq_len(min(k, nrow(u) - 1L))]
      if (all(lw[i] >= lw[near])) found <- c(found, i)
      if (length(found) >= max_seeds) return(found)
    }
  }
  if (length(found) == 0L) which.max(lw) else found
}

is_search_proposal <- function(proposal) isTRUE(proposal$search)

# Rounds follow a fitted proposal once one was fitted (a search round's is
# not).
follows_proposal <- function(library) {
  proposal <- last_proposal(library)
  !is.null(proposal) && !is_search_proposal(proposal)
}

# The library is as a base library for the choice between boxes and a
# proposal: no rounds yet and enough runs to show two modes, or only the
# search round.
deciding_round <- function(library) {
  rounds <- lib_rounds(library)
  (length(rounds) == 0L && lib_n_runs(library) >= proposal_min_runs) ||
    (length(rounds) == 1L && is_search_proposal(rounds[[1]]$proposal))
}

# ---- a mode lost -------------------------------------------------------------

# A base mode whose share was at least this and whose refined share is under
# mode_min_mass is lost.
mode_lost_share <- 0.1

# The base library's problem within a (refined) problem: its runs come
# first, with the base library's own prior.
base_problem <- function(problem) {
  base <- lib_base(problem$library)
  n0 <- lib_n_runs(base)
  problem$library <- base
  problem$C <- if (is.matrix(problem$C)) problem$C[seq_len(n0), , drop = FALSE] else
    problem$C[seq_len(n0)]
  problem$log_prior_run <- lib_log_prior(base)
  problem
}

# The separated modes of the base posterior: list(proposal, mode = the mode
# of each component, share, at = each mode's centre as a theta row), or NULL
# unless two modes hold at least mode_lost_share each. The proposal is fitted
# as a round's would be (tempered, so a coarse library shows its shape),
# leaving the random stream as it was.
base_modes <- function(problem) {
  base <- base_problem(problem)
  range0 <- library_box(base$library)
  q <- sum(range0[2, ] > range0[1, ])
  if (q == 0L || lib_n_runs(base$library) < 2L * q + 2L) return(NULL)
  proposal <- withr::with_preserve_seed(fit_proposal(list(problem = base)))
  mode <- proposal_modes(proposal)
  weight <- vapply(proposal$components, `[[`, numeric(1), "weight")
  share <- as.vector(tapply(weight, mode, sum))
  if (sum(share >= mode_lost_share) < 2L) return(NULL)
  at <- lapply(seq_along(share), function(m) {
    best <- which(mode == m)[which.max(weight[mode == m])]
    u <- matrix(proposal$components[[best]]$centre, 1L)
    stats::setNames(as.data.frame(from_unit(u, proposal$range, proposal$varies)),
                    names(lib_theta(base$library)))
  })
  list(proposal = proposal, mode = mode, share = share, at = at)
}

# The posterior mass of a refined problem on each base mode: its runs given
# to the mode of their most responsible component, as mode_resolution()
# does (a mode's coarse centre may lie a step of the base grid from where
# its mass settles, so no fixed radius around it would do).
mode_masses <- function(modes, p, theta) {
  held <- which(p > 0)
  proposal <- modes$proposal
  u <- unit_coordinates(theta[held, , drop = FALSE], proposal$range, proposal$varies)
  owner <- max.col(mixture_responsibilities(u, proposal$components), ties.method = "first")
  vapply(seq_along(modes$share), function(m) sum(p[held][modes$mode[owner] == m]), numeric(1))
}

# Warn (class griddy_warning_mode_lost) of each base mode holding at least
# mode_lost_share of the base posterior that holds under mode_min_mass of
# the refined one. `modes` from base_modes(), `problem` the refined problem.
warn_mode_lost <- function(modes, problem, source) {
  if (is.null(modes)) return(invisible(NULL))
  p <- grid_posterior(problem, joint = FALSE)$run
  mass <- mode_masses(modes, p, as.matrix(lib_theta(problem$library)))
  lost <- which(modes$share >= mode_lost_share & mass < mode_min_mass)
  if (length(lost) == 0L) return(invisible(NULL))
  where <- vapply(lost, function(m) {
    at <- modes$at[[m]]
    paste0("near ", paste0(names(at), " = ", format(unlist(at), digits = 3), collapse = ", "),
           " (", format(100 * modes$share[m], digits = 2), "% of the base posterior, ",
           format(100 * mass[m], digits = 2), "% now)")
  }, character(1))
  griddy_warn("The base library's posterior had separated modes, and the refined posterior ",
              "has lost ", if (length(lost) == 1L) "one" else "some", ": ",
              paste(where, collapse = "; "), ". The rounds may have zoomed in on another ",
              "mode before this one was resolved",
              if (source == "emulator") ", or the library predicts it poorly",
              ". Refine again with runs there (a finer library around it",
              if (source == "emulator") ", or `simulator =`", "), or check that the mode ",
              "is not the data's.", class = "mode_lost")
}
