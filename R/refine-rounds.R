# refine()'s rounds: the state of a refinement (the exact posterior over runs
# and its resolution table), the test of resolution, and the loop that adds
# runs (or replaces predicted ones) until the posterior is resolved.

# A fit from a refine() that ran out of runs or was stopped carries on where
# it stopped: its last round is compared with the round before, as if the
# rounds had not been interrupted.
unfinished_round <- function(fit) {
  r <- fit$refinement
  if (is.null(r) || r$reason == "resolved") return(NULL)
  r$history[[max(1L, length(r$history) - 1L)]]
}

# Add runs to a problem (a fit is one) round by round until its posterior is
# resolved or `max_runs` are spent; with `simulator = NULL` the runs are
# predicted from the library. With a simulator, predicted runs near the
# posterior are first simulated (see runs_to_replace()). Every finished run
# is kept: when the simulator fails or is interrupted the rounds stop there
# with reason "stopped" and the condition as `failure`, and the problem holds
# the runs simulated until then (also written to `store`, see
# refine_store()). Returns the refined problem, the runs added, the number
# of rounds, why it stopped and the resolution table after each round (the
# first is the problem's own). `settled`, when given, is a function(state,
# previous table) that ends the rounds after a round where it is TRUE
# (reason "settled"): diagnose_gap()'s matched resolution stops where more
# runs cannot resolve a model (settled_in_range()); refine() passes none.
# `proposals`: predicted runs follow the proposal from four parameters, as
# simulated ones do (predicted_round()); refine() asks for it,
# diagnose_gap()'s matched resolution keeps its boxes.
refine_rounds <- function(problem, simulator, max_runs, runs_per_round, progress = FALSE,
                          previous = NULL, store = NULL, settled = NULL, proposals = FALSE) {
  state <- refine_state(problem)
  history <- list(state$table)
  source <- if (is.null(simulator)) "emulator" else "simulator"
  emulator <- NULL
  added <- 0L
  reason <- "resolved"
  failure <- NULL
  while (needs_round(state, if (added > 0L) history[[length(history) - 1L]] else previous,
                     !is.null(simulator),
                     earlier = drift_reference(history, state$problem$library))) {
    if (added >= max_runs) {
      reason <- "max_runs"
      break
    }
    if (!is.null(settled) && added > 0L && settled(state, history[[length(history) - 1L]])) {
      reason <- "settled"
      break
    }
    n_new <- min(runs_per_round, max_runs - added)
    if (is.null(simulator)) {
      step <- predicted_round(state, emulator, n_new, proposals)
      state <- step$state
      emulator <- step$emulator
      n_done <- n_new
    } else {
      step <- simulated_round(state, simulator, n_new, progress, store)
      state <- step$state
      n_done <- step$n
      failure <- step$failure
    }
    added <- added + n_done
    if (n_done > 0L) history[[length(history) + 1L]] <- state$table
    if (!is.null(failure)) {
      reason <- "stopped"
      break
    }
  }
  list(problem = state$problem, runs_added = added, rounds = length(history) - 1L,
       reason = reason, source = source, history = history, failure = failure,
       posterior = state$posterior,
       emulation_error = if (!is.null(emulator)) emulation_error_ratio(emulator, state))
}

# Another round is needed while the posterior is not resolved (against the
# table of the round before, `previous`), is cut off by the last round's box,
# or, with a simulator, rests on predicted runs; or an interval still moved
# since the table `earlier`, a few rounds back (drifted(), refine-ridge.R),
# or the runs thin out beyond an interval's bound (thin_tails()) or end where
# the likelihood has not begun to fall (open_ends()).
needs_round <- function(state, previous, simulating, earlier = NULL) {
  !is_resolved(state$table, previous) || any(truncated_sides(state)) ||
    any(drifted(state$table, earlier, state$p, lib_theta(state$problem$library))) || !explored(state$problem$library) ||
    any(state_thin_tails(state)) || any(state_open_ends(state)) ||
    state$far_mass > far_mass_tol || length(unresolved_modes(state)) > 0L ||
    (simulating && predicted_mass(state) > predicted_tol)
}

# Posterior mass far from every component of the last round's proposal
# (far_mass()) above which a mode is not covered: another round, whose
# proposal gives it a component.
far_mass_tol <- 0.01

# The modes (rows of state$modes) resting on fewer effective runs than the
# whole posterior needs (mode_resolution()).
unresolved_modes <- function(state) {
  modes <- state$modes
  if (is.null(modes)) return(integer())
  which(modes$effective_runs < attr(state$table, "runs")$needed)
}

# One round with the simulator: predicted runs near the posterior simulated
# at their theta, or else a Latin hypercube of new runs in the round's box.
# Returns list(state, n = the runs simulated, failure), the state with every
# run that finished.
simulated_round <- function(state, simulator, n, progress, store) {
  problem <- state$problem
  library <- problem$library
  n_out <- lib_n_out(library)
  if (predicted_mass(state) > predicted_tol) {
    rows <- runs_to_replace(state, n)
    store_round(store, "replace", NULL)
    sim <- simulate_runs(simulator, lib_theta(library)[rows, , drop = FALSE], n_out, progress,
                         keep = store_keeper(store))
    if (length(sim$rows) > 0L) problem <- replace_in_problem(problem, rows[sim$rows], sim$y)
  } else {
    design <- round_design(state, n)
    theta_new <- design$theta
    store_round(store, "add", design$round$box, design$round$proposal)
    sim <- simulate_runs(simulator, theta_new, n_out, progress, keep = store_keeper(store))
    if (length(sim$rows) > 0L) {
      round <- list(box = design$round$box, proposal = design$round$proposal,
                    n = length(sim$rows), source = "simulator", error = NULL)
      problem <- extend_problem(problem, theta_new[sim$rows, , drop = FALSE], sim$y, round,
                                NULL)
    }
  }
  list(state = if (length(sim$rows) > 0L) refine_state(problem) else state,
       n = length(sim$rows), failure = sim$failure)
}

# The exact posterior over runs of a problem and its resolution table (and
# the whole grid_posterior(), which a caller of refine_rounds() may read
# rather than compute again).
refine_state <- function(problem) {
  post <- grid_posterior(problem)
  p <- post$run
  theta <- lib_theta(problem$library)
  list(problem = problem, joint = post$joint, p = p, posterior = post, table = resolution_table(p, theta, scattered = has_proposal_rounds(problem$library)),
       far_mass = far_mass(p, theta, last_proposal(problem$library)),
       modes = mode_resolution(p, theta, last_proposal(problem$library)))
}

# Resolved: no parameter limited by the library, and (after a round) no
# interval bound moved by more than `interval_tol` of the interval's width.
interval_tol <- 0.2

is_resolved <- function(table, previous) {
  # a parameter the library holds constant is not calibrated, nor refined
  if (any(table$limited & !table$constant)) return(FALSE)
  if (is.null(previous)) return(TRUE)
  width <- pmax(table$upper - table$lower, previous$upper - previous$lower)
  moved <- pmax(abs(table$lower - previous$lower), abs(table$upper - previous$upper))
  all(moved <= interval_tol * width)
}

# ---- new runs into the problem -------------------------------------------------

# The problem with runs added (a round of a refined library): their quadratic
# forms appended to C, every run's prior weight recomputed for the new design.
extend_problem <- function(problem, theta_new, y_new, round, rel_var) {
  library <- add_runs(problem$library, theta_new, y_new, round, rel_var)
  rows <- lib_n_runs(problem$library) + seq_len(nrow(theta_new))
  C_new <- fold_extra_logdet(lib_run_quad_forms(library, rows, problem$y_field, problem$setup),
                             problem$prior, problem$n_obs)
  new_griddy_problem(library, problem$y_field, problem$prior, lib_log_prior(library),
                     problem$setup, C = rbind(problem$C, C_new))
}

# The problem with predicted runs `rows` replaced by simulated outputs `y` at
# the same theta: their rows of C recomputed; the design, so the prior
# weights, unchanged.
replace_in_problem <- function(problem, rows, y) {
  library <- replace_runs(problem$library, rows, y)
  C <- problem$C
  C[rows, ] <- fold_extra_logdet(lib_run_quad_forms(library, rows, problem$y_field,
                                                    problem$setup),
                                 problem$prior, problem$n_obs)
  new_griddy_problem(library, problem$y_field, problem$prior, lib_log_prior(library),
                     problem$setup, C = C)
}
