#' Calibrate a simulator by Griddy Gibbs sampling over a library of runs
#'
#' Draws the posterior of the simulator's parameters \eqn{\theta} (a library
#' run), the precision \eqn{\tau} of the misfit and the correlation parameters
#' \eqn{\rho}, for the data model \eqn{y = g(x, \theta) + \epsilon},
#' \eqn{\epsilon \sim N(0, \tau^{-1} R_x \otimes R_t)} of Stewart (2023),
#' ch. 3.2 and Appendices A and B.
#'
#' The quadratic forms \eqn{C_{ig} = (y - g_i)' R_g^{-1} (y - g_i)} are
#' computed once for every run \eqn{i} and correlation grid point \eqn{g},
#' using the Kronecker structure and the tridiagonal inverse of \eqn{R_t}
#' (see [rho_grid()] for the correlation functions). Over a grid of
#' \eqn{R_x} they are matrix products: \eqn{|e' L|^2} with \eqn{R_x^{-1} =
#' L L'} for one output per x setting, \eqn{trace(R_x^{-1} W'W)} (\eqn{W}
#' the AR(1) innovations over t) for several, which griddy computes itself,
#' blocked for the caches and in AVX2/FMA instructions where the processor
#' has them (no optimised BLAS needed), on [griddy_threads()] threads. \eqn{C} does not depend on the number of
#' threads. It is held in double precision, once: \eqn{8 N G} bytes for
#' \eqn{N} runs and \eqn{G} grid points (8 GB at \eqn{10^6 \times 1000}),
#' plus \eqn{4 N G} for the run order of `update = "thesis"`; `print()` of
#' the fit states it, and a precompute whose \eqn{C} needs 1 GB or more says
#' so first (a message of class `griddy_message_memory`). Each iteration
#' then draws by inverse CDF over the library and over the grid:
#'
#' * `update = "collapsed"` (default): \eqn{\theta \mid \rho} and
#'   \eqn{\rho \mid \theta} with \eqn{\tau} integrated out, weights
#'   \eqn{\pi_i (b + C_{ig}/2)^{-(a + n/2)}}, then
#'   \eqn{\tau \mid \theta, \rho \sim Gamma(a + n/2, b + C_{ig}/2)}.
#' * `update = "thesis"`: Appendix A.3 exactly: \eqn{\theta \mid \tau, \rho}
#'   (weights \eqn{\pi_i \exp(-\tau C_{ig}/2)}), then \eqn{\tau}, then
#'   \eqn{\rho \mid \theta, \tau}.
#'
#' Both target the same posterior. With \eqn{\rho} on a grid the thesis's
#' order mixes very badly, because \eqn{\tau} and \eqn{\rho} are tightly
#' coupled: a chain can stay on one grid point for its whole length although
#' the posterior gives that point little mass. The collapsed update removes
#' the coupling; use `"thesis"` to reproduce the thesis's figures, and compare
#' either with [posterior_exact()].
#'
#' **Resolution.** The library is the whole parameter space: when the data
#' determine \eqn{\theta} more finely than the library's spacing, the
#' posterior collapses onto a few runs and its intervals show the spacing, not
#' the data's uncertainty (a truth between runs falls outside them). So
#' `calibrate()` warns (class `griddy_warning_resolution`) when, under the
#' exact posterior over runs, the marginal of some parameter is carried by
#' fewer than 10 effective library values (\eqn{1 / \sum_v m_v^2} over the
#' marginal masses \eqn{m_v} of its distinct values); see
#' [summary()][summary.griddy_fit] and `?refine`.
#'
#' **Convergence.** `calibrate()` also warns (class
#' `griddy_warning_convergence`) when the rank-normalised R-hat of some
#' sampled parameter is above 1.01 (over chains split in halves, so one chain
#' is checked too), or when the total-variation distance between the sampled
#' and the exact posterior over runs is more than 3 times what Monte Carlo
#' error alone would give and above 0.05 (see [summary()][summary.griddy_fit]).
#' The thesis's update stuck on one \eqn{\rho} grid point is caught by one
#' or the other. Short chains can trip the R-hat check by chance: run longer
#' ones.
#'
#' **Field data.** Only the observed points enter: with missing field data
#' (see [field_data()]) \eqn{n} is their number and \eqn{C_{ig}} and
#' \eqn{|R_g|} are those of the observed block of \eqn{R_g} (dense algebra;
#' complete data use the Kronecker shortcuts). With relative standard
#' deviations `sd` the covariance is \eqn{\tau^{-1} S R_g S}. The prior over
#' the correlation grid is uniform over distinct correlation structures (see
#' [rho_grid()]). Replicated measurements (see [field_data()]) enter as
#' their cell means, with relative sd \eqn{1/\sqrt{\sum_r sd_r^{-2}}} and
#' \eqn{R_g} between the means, plus the replicates' pure-error sum of
#' squares in every \eqn{C_{ig}} (in its noise group's), and \eqn{n} counts
#' every measurement: exactly the likelihood of the individual measurements
#' for independent noise (\eqn{\rho = 0}).
#'
#' **Noise groups.** With `noise_groups`, each group \eqn{k} of outputs has
#' its own precision \eqn{\tau_k \sim Gamma(a, b)}; the correlation
#' \eqn{R_g} holds within a group, and groups are independent (so with
#' `noise_groups = "x"` the correlation over x settings plays no part).
#' Integrating every \eqn{\tau_k} out gives
#' \eqn{\sum_k -(a + n_k/2) \log(b + C_{igk}/2)}, which is
#' \eqn{-(a + n/2) \log(b + C^{eff}_{ig}/2)} for one effective misfit
#' \eqn{C^{eff}}, so the \eqn{\theta} and \eqn{\rho} draws are exact as
#' above; after sampling, each kept draw's \eqn{\tau_k \sim Gamma(a + n_k/2,
#' b + C_{igk}/2)} is drawn (reproducible under `seed` and [set.seed()]).
#' `update = "thesis"` conditions on a single \eqn{\tau}, so it takes one
#' group only.
#'
#' **Discrepancy.** With `discrepancy = gp_discrepancy()` the model is
#' \eqn{y = g(x, \theta) + \delta(x, t) + \epsilon}, \eqn{\delta} a Gaussian
#' process with covariance \eqn{\tau^{-1} \lambda K_\ell}: the covariance
#' of the data becomes \eqn{\tau^{-1}(S R_g S + \lambda K_\ell)}, and each
#' combination of \eqn{\rho}, the ratio \eqn{\lambda} and the length
#' scales \eqn{\ell} is one grid point (`fit$grid` gains the columns
#' `delta_ratio`, `delta_length_x` and `delta_length_t`). Everything above
#' holds with \eqn{R_g} read as that covariance. The fit then reports the
#' Bayes factor for a discrepancy ([discrepancy_evidence()]), and warns
#' (class `griddy_warning_gap`) when the data show one: \eqn{\theta} is
#' then the value that best fits the data with a discrepancy, not
#' necessarily the physical one (see [gp_discrepancy()]).
#'
#' **Gap screen.** A fit without a discrepancy (at most 400 measured cells)
#' is screened for one: a lower bound on the log Bayes factor for a
#' [gp_discrepancy()] (from the runs that carry the posterior) and, with one
#' noise precision and no replicates, the leave-block-out checks of
#' [diagnose_gap()] (one x setting times one window of t, the windows
#' scanning t at every width from one correlation length, at FDR 2.5%),
#' which see a gap too local for a smooth discrepancy. A fit with a
#' discrepancy runs the same checks on its model without the discrepancy.
#' The fit warns (class `griddy_warning_gap`) by the rule [diagnose_gap()]
#' decides "other" with: a log Bayes factor above 1 (the screen's bound, or a
#' discrepancy fit's own), or a flagged block; not while the library's
#' resolution limits the fit. Every gap warning says that \eqn{\theta} is
#' then a best-fitting value, not the physical one. `fit$gap_screen` holds
#' `log_bf` (`NA` for a fit with a discrepancy), `blocks` and `n_flagged`. A
#' single measurement (one observed output, no replicates) cannot weigh a
#' gap: `fit$gap_screen$weighable` is then `FALSE` and `summary()` says that
#' griddy cannot tell, as [diagnose_gap()] does.
#'
#' The chains start at a random correlation grid point and, for the thesis
#' update, at \eqn{\tau = 1 / var(y)}; \eqn{\theta} is drawn first.
#'
#' **Speed.** The weights of the \eqn{\theta} draw fall monotonically with
#' \eqn{C_{ig}}, so each column of `C` is sorted once and a draw runs over the
#' head of the sorted list only (its end found by binary search): the runs
#' left out hold less than a fraction `tol` of the total weight, where `tol`
#' is the option `griddy.draw_tol` (default \eqn{2^{-53} \approx 1.1
#' \times 10^{-16}}, double precision relative to the total). Precisely,
#' with \eqn{w_{(1)}} the weight of the run with the smallest \eqn{C_{ig}},
#' every run with \eqn{\pi_{\max} f(C_{ig}) < (tol / N) w_{(1)}} is left out,
#' so each truncated draw is the exact conditional draw restricted to an event
#' of probability above \eqn{1 - tol}: their total-variation distance is
#' below `tol`, and below `n_iter * tol` for a whole chain. Set
#' `options(griddy.draw_tol = 0)` for the full draw over all \eqn{N} runs.
#' `fit$head_length` reports the mean length of the head per draw: the runs
#' a thesis-update draw weighed, or those a collapsed draw (a binary search
#' over their precomputed cumulative weights) could reach.
#'
#' The chains run one after another, or on the workers of a parallel
#' [future][future::plan] plan when the package future.apply is installed
#' (for example `future::plan("multisession", workers = 2)`). Each chain has
#' its own seed, so the draws are the same either way.
#'
#' **Interrupts.** Sequential chains stop at once. Chains on future workers
#' cannot be stopped from outside, so each worker checks a stop file between
#' pieces of its chain (a fiftieth of `n_iter`, at most 1000 iterations): an
#' interrupt (Ctrl-C or Esc)
#' writes that file, and workers that share the session's temporary directory
#' (the `multisession`, `multicore` and `cluster` plans on this machine) stop
#' after their current piece, so the next call finds them free. Workers on
#' other machines, which do not see the file, finish their chains first.
#'
#' @param library A [sim_library()].
#' @param field A [field_data()] object at the library's x and t.
#' @param rho_x,rho_t Correlation grids over x settings and output coordinate,
#'   each in \[0, 1): see [rho_grid()]. 0 (the default) means independence.
#' @param n_iter Total iterations per chain, burn-in included.
#' @param burn_in Iterations discarded at the start of each chain. When
#'   neither `n_iter` nor `burn_in` is given, the collapsed update's chains
#'   are sized to the problem: 5,000 iterations (1,000 burn-in) when those
#'   settle, else `control`'s (see [griddy_control()]).
#' @param thin Keep every `thin`-th iteration after the burn-in.
#' @param chains Number of chains.
#' @param prior The Gamma prior on \eqn{\tau}: a list with `shape` (a) and
#'   `rate` (b). `NULL` (the default) is the thesis's eq. 3.8, a = b =
#'   1e-9. The rate is in the units of the squared outputs: it is negligible
#'   when `n * rate` is small against the smallest misfit \eqn{C_{ig}}. With
#'   the default prior, a warning (class `griddy_warning_prior`) says when it
#'   is not, because the answer then depends on the outputs' units (outputs
#'   of order 1e-4 or smaller). `rate = 0` is scale-free (the posterior is
#'   the same in any units) but improper, so `log_evidence` is `NA`.
#' @param update `"collapsed"` or `"thesis"`; see Details.
#' @param seed `NULL`, or a seed for this call only (the global random number
#'   stream is left as it was). Either way the result is reproducible with
#'   [set.seed()].
#' @param progress Show a progress bar.
#' @param x_power Power of the distance in the correlation over x settings:
#'   2 gives the thesis's eq. 3.14, 1 its Appendix A eq. 5.
#' @param run_weights Optional prior weights \eqn{\pi_i} of the library runs
#'   (non-negative, one per run); `NULL` is uniform.
#' @param noise_groups `NULL` (one precision \eqn{\tau} for every output),
#'   `"x"` (one group per x setting), or labels: one per output coordinate
#'   t (shared across x settings) or one per library output (`n_x * n_t`,
#'   library order). See Details, Noise groups. Every group needs at least
#'   one field measurement.
#' @param discrepancy `NULL` (no model discrepancy, the thesis's model) or a
#'   [gp_discrepancy()]: a Gaussian-process discrepancy \eqn{\delta(x, t)}
#'   added to the model, its ratio and length scales integrated out on a
#'   grid like \eqn{\rho}. See Details, Discrepancy.
#' @param control Settings shared by the calibrating functions, from
#'   [griddy_control()]: the defaults of `n_iter`, `burn_in`, `thin`,
#'   `chains` and `progress`; an argument given in the call overrides its
#'   field.
#' @return An object of class `griddy_fit`: a list holding the kept `draws`
#'   (a data.frame with columns `chain`, `iteration`, `run` (the library row),
#'   `grid_point` (the row of `grid`) and `tau`, or with noise groups one
#'   column `tau_<label>` per group), the `library`, the field
#'   measurements `y_field` (a vector in the library's order, `NA` where missing), the correlation
#'   `grid`, and the precomputed problem: `n_obs`, the `prior`, the log prior
#'   weights of the runs and grid points (`log_prior_run`, `log_prior_grid`),
#'   the correlation `setup` and the quadratic forms `C` (runs x grid points);
#'   then the exact posterior's margins `exact` (a [posterior_exact()] result
#'   without its `joint` table), their `resolution` table (the `parameters`
#'   of `attr(summary(fit), "adequacy")` at level 0.95), the chains'
#'   `diagnostics` (per parameter
#'   the columns `ess_bulk`, `ess_tail`, `rhat` and `mcse` of
#'   [summary()][summary.griddy_fit], and the effective number of draws of
#'   the run index), each computed once for the methods and the checks, the settings of the call (`update`, `control`, `call`), the
#'   chains' `seeds`, the `runtime` of the whole call in seconds, in parts
#'   that add up to it (`precompute`: validation, the quadratic forms and the
#'   sampler's tables; `sampling`; `checks`: the exact margins and the
#'   resolution and convergence checks), and
#'   `head_length`, the mean head length of each chain's \eqn{\theta} draws
#'   (see Details). Each object is held once, so `saveRDS(fit)` writes the
#'   library once. Use [summary()][summary.griddy_fit],
#'   [plot()][plot.griddy_fit], [predict()][predict.griddy_fit],
#'   [as.data.frame()][as.data.frame.griddy_fit] and [coda::as.mcmc.list()]
#'   on it.
#' @references Stewart, H. (2023). Creation and Validation of a Novel Bayesian
#'   Calibration Method with Griddy Gibbs Sampling. MSc thesis, Clemson
#'   University. <https://tigerprints.clemson.edu/all_theses/4177/>
#' @seealso [posterior_exact()] for the exact grid posterior.
#' @examples
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 2000, burn_in = 500, seed = 1)
#' fit
#' summary(fit)
#' @export
calibrate <- function(library, field, rho_x = 0, rho_t = 0, n_iter = control$n_iter,
                      burn_in = control$burn_in, thin = control$thin,
                      chains = control$chains, prior = NULL,
                      update = c("collapsed", "thesis"), seed = NULL,
                      progress = control$progress, x_power = 2, run_weights = NULL,
                      noise_groups = NULL, discrepancy = NULL, control = griddy_control()) {
  start <- proc.time()[["elapsed"]]
  call <- match.call()
  control <- assert_control(control)
  seed <- assert_seed(seed)
  update <- assert_choice(update, "update", c("collapsed", "thesis"), vector_default = TRUE)
  sized <- missing(n_iter) && missing(burn_in) && isTRUE(control$sized) &&
    update == "collapsed"
  control <- sampler_control(n_iter, burn_in, thin, chains, progress)
  problem <- calibration_problem(library, field, rho_x, rho_t, prior, x_power, run_weights,
                                 noise_groups, update, discrepancy)
  check_update_groups(problem, update)
  if (!sized) return(finish_fit(sample_problem(problem, update, control, seed, call, start)))
  finish_fit(sample_sized(problem, update, control, seed, call, start))
}

# The default chain of a collapsed-update calibrate() (see ?griddy_control):
# this long first, and the full `control` length only when its draws have
# not settled (chain_settled()).
sized_chain <- list(n_iter = 5000L, burn_in = 1000L)
# Vehtari et al. (2021) ask for a bulk ESS above 400 before R-hat and the
# ESS themselves are trusted.
sized_min_effective <- 400

sample_sized <- function(problem, update, control, seed, call, start, first = sized_chain) {
  short <- control
  short$n_iter <- first$n_iter
  short$burn_in <- first$burn_in
  if (short$thin > short$n_iter - short$burn_in || short$n_iter >= control$n_iter) {
    return(sample_problem(problem, update, control, seed, call, start))
  }
  tables <- sampler_tables(problem, update)
  fit <- sample_problem(problem, update, short, seed, call, start, tables)
  if (chain_settled(fit)) return(fit)
  again <- proc.time()[["elapsed"]]
  # the same tables (a pass over C at 10^6 runs is not made twice)
  full <- sample_problem(problem, update, control, seed, call, again, tables)
  # the short run's seconds count too: its precompute as precompute, the
  # rest (its chains and their diagnostics) as sampling
  full$runtime[["precompute"]] <- full$runtime[["precompute"]] + fit$runtime[["precompute"]]
  full$runtime[["sampling"]] <- full$runtime[["sampling"]] + again - start -
    fit$runtime[["precompute"]]
  full
}

# Whether a fit's chains pass the convergence checks (warn_convergence()'s
# rules) with at least sized_min_effective effective draws of the run index.
chain_settled <- function(fit) {
  diagnostics <- stored_diagnostics(fit)
  exact_run <- exact_margins(fit)$run
  tv <- run_tv_distance(fit$draws$run, exact_run)
  problems <- convergence_problems(diagnostics$rhat, tv,
                                   expected_tv(exact_run, diagnostics$effective_draws))
  length(problems$rhat) == 0L && !problems$tv &&
    diagnostics$effective_draws >= sized_min_effective
}

# The thesis's update draws theta given one tau: it has no form for several.
check_update_groups <- function(problem, update) {
  if (update == "thesis" && n_noise_groups(problem) > 1L) {
    griddy_abort("`update = \"thesis\"` conditions on a single precision tau, but the fit has ",
                 n_noise_groups(problem), " noise groups; use `update = \"collapsed\"`.",
                 class = "input")
  }
}

n_noise_groups <- function(problem) length(problem$setup$group_sizes)

# Draw the posterior of a calibration problem (validated inputs, C): the
# sampler half of calibrate(), shared with refine(); the fit it returns is
# finished by finish_fit(). `start` is the elapsed time at which the call
# began (validation and precompute count from there); `tables` the
# sampler's tables, when already computed.
sample_problem <- function(problem, update, control, seed, call,
                           start = proc.time()[["elapsed"]],
                           tables = sampler_tables(problem, update)) {
  force(tables)  # computed here, so that it counts in the precompute
  precompute <- proc.time()[["elapsed"]] - start
  run_all <- function() {
    seeds <- sample.int(.Machine$integer.max, control$chains)
    chains <- run_chains(problem, tables, update, control, seeds)
    list(seeds = seeds, chains = chains, group_tau = group_tau_draws(problem, chains))
  }
  out <- with_seed(seed, run_all())
  sampling <- proc.time()[["elapsed"]] - start - precompute
  new_griddy_fit(problem, out, update, control, call,
                 runtime = c(precompute = precompute, sampling = sampling, checks = 0))
}

sampler_control <- function(n_iter, burn_in, thin, chains, progress) {
  c(sampler_settings(n_iter, burn_in, thin, chains),
    list(progress = assert_flag(progress, "progress")))
}

# What the theta draws need besides C, computed once before any chain runs:
# the truncated CDF of every column (collapsed update) or the run order of
# every column (thesis update); see the Details of calibrate().
sampler_tables <- function(problem, update, tol = draw_tolerance()) {
  if (update == "collapsed") {
    list(heads = collapsed_heads_cpp(problem$C, problem$log_prior_run,
                                     problem$prior$shape + problem$n_obs / 2,
                                     problem$prior$rate, tol, griddy_threads()))
  } else {
    list(order = run_order_cpp(problem$C, griddy_threads()))
  }
}

# The bound on the total-variation distance between a truncated theta draw
# and the full one: option griddy.draw_tol, 2^-53 by default.
draw_tolerance <- function() {
  tol <- getOption("griddy.draw_tol", 2^-53)
  if (!is.numeric(tol) || length(tol) != 1L || is.na(tol) || tol < 0 || tol >= 1) {
    griddy_abort("Option `griddy.draw_tol` must be a single number in [0, 1); received ",
                 paste(format(tol), collapse = ", "), ".")
  }
  tol
}

# The options of gibbs_chain_cpp() (src/gibbs_chain.cpp, struct
# SamplerOptions) that do not change along a chain.
sampler_options <- function(problem, update, control, tol = draw_tolerance()) {
  list(update = update, n_obs = problem$n_obs, shape = problem$prior$shape,
       rate = problem$prior$rate, tol = tol, burn_in = control$burn_in,
       thin = control$thin, logdet = problem$setup$logdet,
       log_prior_run = problem$log_prior_run, log_prior_grid = problem$log_prior_grid)
}

# Run every chain from its own seed, so each chain's draws depend only on its
# seed (not on the order the chains run in, nor on where they run), and the
# whole fit on set.seed(). Under a parallel future plan (see
# future::plan()) the chains run on its workers, except on a cluster
# scheduler's plan, where a job would wait longer than the chains take;
# otherwise one after another.
run_chains <- function(problem, tables, update, control, seeds) {
  inputs <- list(C = problem$C, tables = tables,
                 options = sampler_options(problem, update, control),
                 tau_start = 1 / stats::var(problem$y_field, na.rm = TRUE))
  if (griddy_workers(scheduled = FALSE) > 1L) {
    # an interrupt here leaves the futures running: tell them to stop (see
    # ?calibrate, Interrupts)
    stop_file <- tempfile("griddy-stop-")
    done <- FALSE
    on.exit(if (!done) file.create(stop_file), add = TRUE)
    out <- griddy_map(seeds, run_chain, inputs = inputs, control = control, bar = NULL,
                      stop_file = stop_file, scheduled = FALSE)
    done <- TRUE
    return(out)
  }
  bar <- if (control$progress) {
    cli::cli_progress_bar("Sampling", total = control$chains * control$n_iter,
                          .envir = environment())
  }
  lapply(seeds, run_chain, inputs = inputs, control = control, bar = bar)
}

# One chain: in one piece, or, with a progress bar or a stop file, in pieces
# of a fiftieth of n_iter but at most `max_piece` iterations (a piece is what
# a worker finishes after an interrupt), each piece continuing the last one's
# state and random stream, so the draws are the same either way.
max_piece <- 1000L

run_chain <- function(seed, inputs, control, bar, stop_file = NULL) {
  piece <- if (is.null(bar) && is.null(stop_file)) {
    control$n_iter
  } else {
    min(max(1L, ceiling(control$n_iter / 50)), max_piece)
  }
  with_seed(seed, {
    state <- list(grid_point = sample.int(ncol(inputs$C), 1L) - 1L, tau = inputs$tau_start)
    if (!is.finite(state$tau)) state$tau <- 1
    pieces <- list()
    head_total <- 0
    for (first in seq(1L, control$n_iter, by = piece)) {
      if (!is.null(stop_file) && file.exists(stop_file)) {
        griddy_abort("Interrupted: the chain stopped at iteration ", first - 1L, ".",
                     class = "interrupted")
      }
      options <- c(inputs$options, n_iter = min(piece, control$n_iter - first + 1L),
                   first_iter = first)
      res <- gibbs_chain_cpp(inputs$C, inputs$tables, options, state$grid_point, state$tau)
      state <- list(grid_point = res$grid_state, tau = res$tau_state)
      head_total <- head_total + res$head_total
      pieces[[length(pieces) + 1L]] <- res[c("run", "grid_point", "tau")]
      if (!is.null(bar)) cli::cli_progress_update(inc = options$n_iter, id = bar)
    }
    out <- lapply(c(run = "run", grid_point = "grid_point", tau = "tau"),
                  function(v) unlist(lapply(pieces, `[[`, v), use.names = FALSE))
    out$head_length <- head_total / control$n_iter
    out
  })
}

# With noise groups, each kept draw's precisions tau_k | run, grid point ~
# Gamma(a + n_k/2, b + C_k/2), drawn after the chains from R's stream (the
# sampler's own tau is that of the folded C): a draws x groups matrix with
# columns tau_<label>, NULL for one group.
group_tau_draws <- function(problem, chains) {
  if (n_noise_groups(problem) == 1L) return(NULL)
  run <- unlist(lapply(chains, `[[`, "run"), use.names = FALSE)
  grid <- unlist(lapply(chains, `[[`, "grid_point"), use.names = FALSE)
  Ck <- matrix(0, length(run), n_noise_groups(problem))
  for (g in unique(grid)) {
    rows <- which(grid == g)
    runs <- unique(run[rows])
    Ck[rows, ] <- run_group_forms(problem, runs, g)[match(run[rows], runs), , drop = FALSE]
  }
  shape <- problem$prior$shape + problem$setup$group_sizes / 2
  tau <- vapply(seq_len(ncol(Ck)), function(k) {
    stats::rgamma(nrow(Ck), shape = shape[k], rate = problem$prior$rate + Ck[, k] / 2)
  }, numeric(nrow(Ck)))
  tau <- matrix(tau, nrow(Ck))
  colnames(tau) <- paste0("tau_", problem$setup$pattern$labels)
  tau
}

# The fit is the problem (library, field, grid, setup, C, priors: each held
# once) plus the draws, the settings of the call, the exact posterior's
# margins (exact_margins()), their resolution table (resolution_limited())
# and the chains' diagnostics (fit_diagnostics()), computed here once for
# every method that reads them. `runtime` holds the seconds of the parts of the call: its
# "checks" part grows by the time the margins take here.
new_griddy_fit <- function(problem, out, update, control, call, runtime) {
  kept <- seq(control$burn_in + control$thin, control$n_iter, by = control$thin)
  draws <- chain_draws(out$chains, kept)
  if (!is.null(out$group_tau)) draws <- cbind(draws[names(draws) != "tau"], out$group_tau)
  start <- proc.time()[["elapsed"]]
  fit <- structure(
    c(list(draws = draws), problem,
      list(exact = exact_from_problem(problem, joint = FALSE), update = update,
           control = control, seeds = out$seeds, call = call, runtime = runtime,
           head_length = vapply(out$chains, function(d) d$head_length, numeric(1)))),
    class = "griddy_fit"
  )
  fit$resolution <- resolution_table(fit$exact$run, lib_theta(problem$library),
                                    scattered = has_proposal_rounds(problem$library))
  fit$diagnostics <- fit_diagnostics(fit)
  fit$runtime[["checks"]] <- runtime[["checks"]] + proc.time()[["elapsed"]] - start
  fit
}

# The chains' kept draws, one after another, as a data.frame with columns
# chain, iteration, run, grid_point and tau (columns_frame(): what
# data.table::rbindlist() and as.data.frame() made, without their
# conversions).
chain_draws <- function(chains, kept) {
  column <- function(v) unlist(lapply(chains, `[[`, v), use.names = FALSE)
  lengths <- vapply(chains, function(d) length(d$run), 1L)
  columns_frame(list(chain = rep(seq_along(chains), lengths),
                     iteration = rep(kept, length(chains)), run = column("run"),
                     grid_point = column("grid_point"), tau = column("tau")))
}

# The exact posterior's margins of a fit (a griddy_exact without the joint
# table): stored by new_griddy_fit(); recomputed for a fit saved before they
# were.
exact_margins <- function(fit) {
  if (!is.null(fit$exact)) return(fit$exact)
  exact_from_problem(fit, joint = FALSE)
}

# Evaluate `code` with the random number stream seeded by `seed`, leaving the
# caller's stream as it was (withr::with_seed()); with `seed = NULL`, in the
# caller's stream.
with_seed <- function(seed, code) {
  if (is.null(seed)) code else withr::with_seed(seed, code)
}
