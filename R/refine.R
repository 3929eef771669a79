#' Refine the library where the posterior has its mass
#'
#' Griddy Gibbs treats the library as the whole parameter space, so when the
#' true \eqn{\theta} lies between runs and the data are many, the posterior
#' collapses onto the runs nearest the truth and its intervals show the
#' library's spacing, not the data's uncertainty (see the warning of
#' [calibrate()] and the `resolution` column of
#' [summary()][summary.griddy_fit]). `refine()` adds runs where the posterior
#' has its mass, round by round, until every parameter's interval is resolved
#' or `max_runs` runs have been added, and returns the fit calibrated on the
#' refined library, with the same settings. The engine is unchanged: the
#' draws are inverse-CDF draws over a finite library, which is now finer
#' where it matters.
#'
#' **A round.** From the exact posterior over runs ([posterior_exact()]), the
#' box of each parameter's central 99%, widened on each side by the
#' library's local spacing (the spread of the runs nearest the most probable
#' one, at least one step of a grid) or a quarter of its width, whichever is
#' larger, and kept inside the library's range, receives a Latin hypercube of
#' `runs_per_round` new runs. A collapsed posterior thus zooms in around its
#' run; a spread one is filled in. When the posterior's 95% interval comes
#' within a tenth of the last round's box, and an eighth of the interval's
#' width, of the box's edge (and that box stops short of the library's
#' range), the posterior is cut off by where the dense runs end,
#' not by the data: the next box then reaches a whole box width further, so
#' a box that missed the truth finds it in a few rounds.
#'
#' **A round in four or more parameters.** A box of the marginals' ranges is
#' then mostly empty of posterior mass, and cannot hold two modes. A round
#' instead draws its runs from a proposal fitted to the weighted library, as
#' population Monte Carlo and adaptive multiple importance sampling do
#' (Cappe et al. 2004; Cornuet et al. 2012): a mixture of multivariate t
#' distributions (4 degrees of freedom), one per cluster of the weighted
#' runs (a Gaussian mixture fitted by weighted EM, so separated modes get a
#' component each), fitted to the posterior over runs tempered until it rests
#' on at least \eqn{\max(50, 10p)} effective runs (so a first, coarse
#' library gives a wide proposal, which narrows round by round), plus a
#' defensive 15% drawn uniformly over the library's range (Hesterberg 1995),
#' so no region, and no mode, stops receiving runs. The tempering uses the
#' likelihood at the best run's noise level, whose tails are Gaussian; the
#' posterior itself is the package's, with the noise integrated out. In two
#' or three parameters the rounds follow such a proposal too when the one
#' fitted to the base library finds separated modes (a box spanning two
#' modes spreads its runs over the empty space between them, and the rounds
#' after zoom in on one); otherwise they are the boxes above.
#'
#' **A coarse start.** A base posterior resting on fewer effective runs than
#' a proposal is fitted to shows the posterior only at the library's
#' resolution: the runs nearest two modes may lie hundreds of log units
#' apart, and rounds that zoom in on the better lose the other. The first
#' round is then a search: half its runs a Latin hypercube over the
#' library's range, half drawn around each local maximum of the base
#' posterior over the runs' neighbourhood graph (a run more probable than
#' its \eqn{2p} nearest; up to 8, within a factor 100 of the best at the
#' proposal's tempering), from a t component as wide as the library's
#' spacing there. When it seeded several maxima, the rounds after follow a
#' proposal fitted to the library the search has grown, in any number of
#' parameters, whose defensive share keeps drawing runs over the whole range
#' (boxes zoomed in on the first mode the search found). When it seeded one,
#' below four parameters, it draws around it uniformly from a box one step
#' of the spacing wide on each side, and the rounds after are the boxes
#' above unless the library it grew shows separated modes. When the base
#' posterior had
#' separated modes (the basins of such maxima) each holding at least 10%,
#' and the refined posterior holds under 2% on one around which the rounds
#' put too few runs to see it (fewer than a quadratic's coefficients within
#' a step of the base library's spacing), `refine()` warns (class
#' `griddy_warning_mode_lost`), naming where the mode was and its shares;
#' so it does when a round's proposal had separated modes each holding 10%
#' of its weight and one now holds under 2% though it held 10% of the
#' posterior then, or rests on too few effective runs of its own to tell its
#' share. With or without a simulator.
#'
#' **The prior stays the library's.** A library's equal weights over runs
#' are a uniform prior over \eqn{\theta} only while runs fill the range
#' evenly. Each run of the refined library is therefore weighed by the prior
#' density over the density of the design that produced it (the base
#' library spread over its range plus every round's hypercube over its box,
#' or its proposal's density: the balance heuristic of multiple importance
#' sampling), so the prior stays uniform over the library's range. The weights travel
#' with the library: [calibrate()] on it uses them.
#'
#' **Resolved** means that every parameter's marginal posterior spreads
#' over at least 10 effective distinct values (\eqn{1 / \sum_v m_v^2}, the
#' criterion of [summary()][summary.griddy_fit]; for a Gaussian marginal of
#' sd \eqn{s} on runs spaced \eqn{h} apart this is \eqn{3.5 s / h}, so runs
#' at most about a third of a standard deviation apart), that no interval
#' bound moved by more than a fifth of the interval's width in the last
#' round, and that no interval is cut off by the last box (above). In four
#' or more parameters each run of a scattered library has its own value of
#' every parameter, so effective values count runs: the posterior over runs
#' (and in a library grown by proposals in fewer parameters)
#' must also rest on at least \eqn{\max(100, 20p)} effective runs
#' (\eqn{1 / \sum_i p_i^2}; 11 effective runs in 11 parameters are not
#' resolved), the Pareto-smoothed importance sampling \eqn{\hat k} of its
#' weights (`loo::psis()`, Vehtari et al. 2024) must stay below
#' \eqn{\min(1 - 1/\log_{10} S, 0.7)} for \eqn{S} runs, and no more than
#' 1% of the posterior may lie far from every component of the last
#' proposal (a mode the proposal has not covered yet). [summary()][summary.griddy_fit]
#' and [calibrate()]'s warning apply the same test. When the last proposal
#' has separated modes each holding at least 2% of the posterior, `refine()`
#' also asks each mode for as many effective runs of its own as the whole
#' needs: a mode's share is estimated from its own runs, and one resting on
#' a few is often too small (on a folded 4-parameter system, 20% where
#' symmetry makes it 50%). The warning at `max_runs` names such a mode.
#' A posterior along a curved or weakly identified band (two parameters
#' identified only through their product; a banana) reaches past what a few
#' broad components draw, and its missing ends are invisible to checks
#' that look at runs. So once a proposal is fitted to the posterior itself
#' (untempered), half its t mixture is local: components centred on runs
#' resampled from the posterior and on the runs at both ends of it along
#' each parameter and principal direction, each with the covariance of its
#' nearest posterior runs, doubled, so they follow a band's local direction
#' past its explored end. A library grown by proposals is resolved only
#' after its last three rounds drew such local components, and while no
#' interval bound moved by more than a fifth of its width over those three
#' rounds (the posterior with them dropped) nor has more of the posterior
#' beyond it now than its 2.5% and three Monte Carlo sds; the warning at `max_runs`
#' then has class `griddy_warning_reach` too and names the parameters whose
#' intervals still moved. Nor is it resolved while the runs outside an
#' interval carry fewer effective runs than their share of the
#' posterior's (the runs thin out before the posterior does, as at the
#' unreached end of a ridge), nor while the best-fitting runs end, along a
#' parameter, where the likelihood has not begun to fall (within one log
#' unit of the best run) short of the range's edge; the warning names those
#' parameters too.
#' `refine()` of a resolved fit returns it unchanged; when `max_runs` runs
#' are spent first, the result warns (class `griddy_warning_resolution`) and
#' `refine()` of it carries on where it stopped. Otherwise the refined fit
#' is checked as [calibrate()]'s is: it warns when its chains have not
#' converged (class `griddy_warning_convergence`) and when the data show a
#' gap (class `griddy_warning_gap`; the screen is in `$gap_screen`).
#'
#' **With a simulator**, new runs are simulated: `simulator(theta, ...)`
#' receives a data.frame of \eqn{\theta} rows (the library's columns) and
#' returns the matrix of their outputs in the library's layout (one row per
#' run, blocks by x setting; see [sim_library()]). The calls are spread over
#' the workers of the user's [future][future::plan] plan when future.apply is
#' installed (a `multisession` plan, or cluster workers through
#' future.batchtools), in chunks, with a progress bar; each chunk gets its
#' own random stream, so a stochastic simulator is reproducible with `seed`.
#' Runs of the library that were predicted rather than simulated (an
#' [emulated_library()], or rounds of `refine()` without a simulator) are
#' simulated first where the posterior has its mass, at their own
#' \eqn{\theta}, so resolution is judged on simulated runs: `refine(fit,
#' simulator)` on a fit over an emulated library replaces the emulated runs
#' near the posterior with simulated ones, even when the fit was resolved.
#'
#' **Nothing is lost.** Every chunk of runs the simulator finishes joins the
#' refined library at once. When the simulator fails or is interrupted, the
#' error (class `griddy_error_simulator`, or `griddy_error_interrupted`)
#' carries the fit refined with every run finished so far as `e$fit` (also
#' `rlang::last_error()$fit`), and `refine(e$fit, simulator)` carries on.
#' With `file`, every finished chunk is also appended to an HDF5 library
#' ([write_library()], with its safe appends and lock; needs hdf5r) and the
#' rounds listed beside it in `<file>.rounds.csv`; `refine(fit, simulator,
#' file = file)` with the same file, after a failure or in a new session,
#' first takes the runs in the file that `fit` does not hold, so no run is
#' simulated twice. The file is a library like any other:
#' `hdf5_library(file)` opens the simulated runs.
#'
#' **Without a simulator**, new runs are predicted from the library itself
#' (tensor-product cubic interpolation on a full-factorial grid; a Gaussian
#' process, RobustGaSP's `ppgasp()`, on the runs nearest the region for a
#' scattered design, or a local quadratic fit when RobustGaSP is not
#' installed). The prediction error, measured on the library by leave-one-out
#' and summarised by its leading principal directions over the outputs,
#' enters the likelihood of every predicted run as an extra covariance,
#' scaled by the prediction's relative variance there (0 at a library run).
#' The error is correlated over the outputs, so it is not averaged away by
#' many data: intervals widen where the library is too coarse to tell the
#' runs apart. The error model is an estimate: when the library predicts
#' its own runs near the posterior worse than the noise (leave-one-out
#' error over the fitted noise sd above 1, `$refinement$emulation_error`),
#' the intervals may be biased, and `refine()` says so (a warning of class
#' `griddy_warning_emulation`): refine with the simulator there. The noise
#' variance that puts this covariance on the scale of \eqn{\tau^{-1}} is
#' the posterior mean of \eqn{1/\tau}, updated every round for all
#' rounds; with it the model stays conjugate in \eqn{\tau}, exactly so
#' for `update = "collapsed"` and [posterior_exact()] (the thesis's update
#' draws \eqn{\theta} given
#' \eqn{\tau} from the same folded misfit, an approximation).
#'
#' @param fit A `griddy_fit` from [calibrate()] or `refine()`, whose runs are
#'   weighed equally a priori (no `run_weights`) or by an earlier `refine()`.
#' @param simulator `NULL`, or a function of a data.frame of \eqn{\theta}
#'   rows (and `...`) that returns their outputs: see Details.
#' @param max_runs The most runs to add (or, with a simulator, to simulate in
#'   place of predicted ones), over all rounds. The default (`control`'s), 4000,
#'   resolved each of twelve 2- and 3-parameter trials in
#'   `bench/refine-max-runs.R` (2 parameters took 400 to 800 runs, 3
#'   parameters 1600 to 2800).
#' @param ... Further arguments to `simulator`.
#' @param runs_per_round Runs added per round; `NULL` is
#'   \eqn{100 \times 2^{p - 1}} for \eqn{p} varying parameters (with a
#'   simulator, \eqn{50 p} from four), at most `max_runs`.
#' @param file `NULL`, or the path of an HDF5 file that keeps every simulated
#'   run as it finishes (with a simulator only), and from which a later
#'   `refine()` resumes: see Details.
#' @param seed `NULL`, or a seed for this call only; either way the result is
#'   reproducible with [set.seed()].
#' @param progress Show progress (the simulator's runs and the sampling).
#' @param control Settings shared by the calibrating functions, from
#'   [griddy_control()]; an argument given in the call overrides its field.
#' @return A `griddy_fit` calibrated on the refined library (a library of
#'   class `refined_library`, usable wherever a library is), with the settings
#'   of `fit` (correlation grids, prior, update, iterations, chains), and an
#'   element `refinement`: a list with `runs_added`, `rounds`, `reason` (why
#'   it stopped: `"resolved"` or `"max_runs"`; `"stopped"` in the `fit` of
#'   an error when the simulator failed), `source` (`"simulator"` or
#'   `"emulator"`), `history`, the per-parameter resolution table after
#'   each round, and `emulation_error` (without a simulator; see Details). A
#'   fit that is already resolved (and, with a simulator, rests on simulated
#'   runs) is returned as it was.
#' @seealso [calibrate()], [summary.griddy_fit()], [posterior_exact()]
#' @references Cappe, O., Guillin, A., Marin, J.-M. and Robert, C. P. (2004).
#'   Population Monte Carlo. Journal of Computational and Graphical
#'   Statistics 13, 907-929.
#'
#'   Cornuet, J.-M., Marin, J.-M., Mira, A. and Robert, C. P. (2012).
#'   Adaptive multiple importance sampling. Scandinavian Journal of
#'   Statistics 39, 798-812.
#'
#'   Hesterberg, T. (1995). Weighted average importance sampling and
#'   defensive mixture distributions. Technometrics 37, 185-194.
#'
#'   Vehtari, A., Simpson, D., Gelman, A., Yao, Y. and Gabry, J. (2024).
#'   Pareto smoothed importance sampling. Journal of Machine Learning
#'   Research 25(72), 1-58.
#'
#'   Ritter, C. and Tanner, M. A. (1992). Facilitating the Gibbs
#'   sampler: the Gibbs stopper and the griddy-Gibbs sampler. Journal of the
#'   American Statistical Association 87, 861-868.
#' @examples
#' sim <- function(theta) {
#'   t <- seq(0, 1, length.out = 40)
#'   t(vapply(theta$k, function(k) sin(k * t), numeric(40)))
#' }
#' lib <- sim_library(data.frame(k = seq(1, 4, by = 0.5)), sim(data.frame(k = seq(1, 4, by = 0.5))))
#' set.seed(1)
#' field <- field_data(sim(data.frame(k = 2.23)) + rnorm(40, sd = 0.02), t = lib$t)
#' fit <- suppressWarnings(calibrate(lib, field, n_iter = 2000, burn_in = 500, seed = 1))
#' refined <- refine(fit, sim, max_runs = 300, seed = 1)
#' refined$refinement$reason
#' summary(refined)
#' @export
refine <- function(fit, simulator = NULL, max_runs = control$max_runs, ...,
                   runs_per_round = control$runs_per_round, file = NULL, seed = NULL,
                   progress = control$progress, control = griddy_control()) {
  call <- match.call()
  control <- assert_control(control)
  check_refinable(fit)
  if (!is.null(simulator) && !is.function(simulator)) {
    griddy_abort("`simulator` must be NULL or a function of a data.frame of theta rows; ",
                 "received ", class(simulator)[1], ".")
  }
  max_runs <- assert_count(max_runs, "max_runs")
  runs_per_round <- if (is.null(runs_per_round)) {
    min(default_runs_per_round(lib_theta(fit$library), proposals = !is.null(simulator),
                               predicted = is.null(simulator)), max_runs)
  } else {
    assert_count(runs_per_round, "runs_per_round")
  }
  seed <- assert_seed(seed)
  progress <- assert_flag(progress, "progress")
  if (!is.null(file)) {
    file <- assert_string(file, "file")
    if (is.null(simulator)) {
      griddy_abort("`file` keeps the runs a simulator makes, but `simulator` is NULL; give ",
                   "the simulator, or leave `file` out.")
    }
    require_package("hdf5r", "to keep refine()'s runs in `file`")
  }
  store <- refine_store(file, fit$library)
  if (!is.null(simulator)) simulator <- simulator_caller(simulator, list(...))
  with_seed(seed, refine_fit(fit, simulator, max_runs, runs_per_round, progress, call, store))
}

check_refinable <- function(fit) {
  if (!inherits(fit, "griddy_fit")) {
    griddy_abort("`fit` must be a griddy_fit from calibrate() or refine(); received ",
                 class(fit)[1], ".")
  }
  if (!isTRUE(all.equal(fit$log_prior_run, lib_log_prior(fit$library)))) {
    griddy_abort("refine() keeps the library's own prior over runs, but this fit was ",
                 "calibrated with `run_weights`; calibrate without them first.")
  }
}

default_runs_per_round <- function(theta, proposals = FALSE, predicted = FALSE) {
  p <- sum(vapply(theta, function(v) max(v) > min(v), logical(1)))
  # a proposal that follows the posterior (four or more parameters) needs no
  # box's doubling per parameter, and more rounds adapt it better; predicted
  # runs cost little beside a round's refitting, so their rounds are larger
  if (p >= proposal_min_parameters && (proposals || predicted)) {
    per <- if (predicted) predicted_round_per_parameter else proposal_round_per_parameter
    return(as.integer(per * p))
  }
  100L * 2L^(max(p, 1L) - 1L)
}

proposal_round_per_parameter <- 50
predicted_round_per_parameter <- 200

# The runs in `store` that the fit lacks, the rounds, then one calibration of
# the refined library with the fit's settings. A simulator that failed or
# was interrupted stops the rounds; the fit of every run finished travels
# with the error (stop_refinement()).
refine_fit <- function(fit, simulator, max_runs, runs_per_round, progress, call, store) {
  resumed <- store_resume(store, fit)
  # runs from the file are a round: judged against the fit they refine
  previous <- if (resumed$n > 0L) refine_state(fit)$table else unfinished_round(fit)
  modes <- base_modes(resumed$problem)
  rounds <- refine_rounds(resumed$problem, simulator, max_runs, runs_per_round, progress,
                          previous = previous, store = store, proposals = TRUE)
  rounds$runs_added <- rounds$runs_added + resumed$n
  if (rounds$runs_added == 0L) {
    if (!is.null(rounds$failure)) stop_refinement(rounds$failure, fit, store)
    cli::cli_inform(c(i = "The posterior is already resolved: nothing to refine."),
                    class = "griddy_message_resolved")
    return(fit)
  }
  out <- sample_problem(rounds$problem, fit$update, fit$control, seed = NULL, call = call)
  out$refinement <- rounds[c("runs_added", "rounds", "reason", "source", "history",
                             "emulation_error")]
  if (!is.null(rounds$failure)) {
    stop_refinement(rounds$failure, finish_fit(out, warn = FALSE), store)
  }
  # refine()'s own resolution warning says why the rounds stopped short; a
  # resolved refinement has nothing to warn of
  finish_fit(out, resolution = function(fit) {
    if (rounds$reason != "resolved") warn_unresolved(refine_state(rounds$problem), rounds)
    warn_mode_lost(modes, rounds$problem, rounds$source)
  })
}

# The simulator failed or was interrupted: an error that carries the fit of
# every run finished (`fit`) and says how to carry on. A griddy error of the
# simulator's output (shape, non-finite values) keeps its class.
stop_refinement <- function(failure, fit, store) {
  interrupted <- inherits(failure, "interrupt")
  kept <- if (is.null(fit$refinement)) 0L else fit$refinement$runs_added
  where <- if (is.null(store)) "" else paste0(" and in ", store$file)
  rlang::abort(
    paste0(if (interrupted) "refine() was interrupted" else "The simulator failed",
           " in a round of refine(). The ", kept, " run(s) it simulated before are kept in ",
           "the error's `fit` (`e$fit`, or `rlang::last_error()$fit`)", where,
           ": `refine(e$fit, simulator)`",
           if (!is.null(store)) paste0(" (or `refine(fit, simulator, file = \"", store$file,
                                       "\")` in a new session)"),
           " carries on from there."),
    class = c(if (interrupted) "griddy_error_interrupted" else "griddy_error_simulator",
              grep("^griddy_error_", class(failure), value = TRUE), "griddy_error"),
    fit = fit, parent = if (!interrupted) failure, call = NULL)
}

# Said plainly when the library cannot stand in for the simulator: see
# emulation_error_ratio().
emulation_error_threshold <- 1

warn_emulation <- function(ratio) {
  if (is.null(ratio) || !is.finite(ratio) || ratio <= emulation_error_threshold) return()
  griddy_warn("refine() predicted its runs from the library, which predicts its own runs ",
              "near the posterior with an error ", format(ratio, digits = 2), " times the ",
              "noise (leave-one-out). The intervals then rest on an estimate of that error ",
              "and may be biased; refine with the simulator (`simulator =`), or a finer ",
              "library, where you can.", class = "emulation")
}

# One reason per mode resting on too few effective runs, naming where it is
# (its most probable run) and the share of the posterior it holds.
unresolved_mode_reasons <- function(state) {
  if (is.null(state$modes)) return(character())
  modes <- state$modes[unresolved_modes(state), , drop = FALSE]
  vapply(seq_len(nrow(modes)), function(i) {
    at <- modes$at[[i]]
    paste0("the mode near ", paste0(names(at), " = ", format(unlist(at), digits = 3),
                                    collapse = ", "),
           ", holding ", format(100 * modes$mass[i], digits = 2), "% of the posterior, rests on ",
           format(modes$effective_runs[i], digits = 3), " effective runs (",
           attr(state$table, "runs")$needed, " needed): its share may be wrong")
  }, character(1))
}

# refine() ran out of runs: say which parameters are not resolved and why.
warn_unresolved <- function(state, rounds) {
  tab <- state$table
  previous <- rounds$history[[max(1L, length(rounds$history) - 1L)]]
  cut <- colSums(truncated_sides(state)) > 0
  moved <- pmax(abs(tab$lower - previous$lower), abs(tab$upper - previous$upper)) >
    interval_tol * pmax(tab$upper - tab$lower, previous$upper - previous$lower)
  runs <- run_resolution_reason(attr(tab, "runs"))
  few_values <- tab$effective_values < resolution_min_values
  drift <- drifted(tab, drift_reference(rounds$history, state$problem$library), state$p,
                   lib_theta(state$problem$library))
  thin <- state_thin_tails(state)
  open <- state_open_ends(state)
  why <- ifelse(tab$limited & !tab$constant & (few_values | is.null(runs)),
                paste0(format(tab$effective_values, digits = 2), " effective values"),
         ifelse(cut, "its interval reaches the edge of the refined region",
         ifelse(moved, "its interval still moved in the last round",
         ifelse(drift, paste0("its interval still moved over the last ", drift_rounds,
                              " rounds: the runs have not followed the posterior to its end"),
         ifelse(thin, paste0("the runs outside its interval are fewer than their share ",
                             "of the posterior's: the runs thin out before the posterior does, ",
                             "which may go on past them"),
         ifelse(open, paste0("the runs end where the likelihood has not begun to fall: ",
                             "the posterior may go on past them"),
                NA))))))
  bad <- !is.na(why)
  extra <- c(if (!is.null(runs)) paste0("the posterior rests on ", runs),
             if (state$far_mass > far_mass_tol) {
               paste0(format(100 * state$far_mass, digits = 2), "% of the posterior lies ",
                      "far from where the last round's runs went: a mode may be lost or ",
                      "unresolved")
             },
             unresolved_mode_reasons(state),
             if (!explored(state$problem$library)) {
               paste0("the last rounds have not yet explored the posterior's ends (its ",
                      "ridges and tails) from where it now lies")
             })
  if (length(extra) > 0L) {
    why <- c(why[bad], extra)
    tab <- data.frame(parameter = c(tab$parameter[bad], rep("all", length(extra))))
    bad <- rep(TRUE, length(why))
  }
  if (rounds$source == "simulator" && predicted_mass(state) > predicted_tol) {
    why <- c(why[bad], "the posterior still rests on predicted runs")
    tab <- data.frame(parameter = c(tab$parameter[bad], "all"))
    bad <- rep(TRUE, length(why))
  }
  griddy_warn("refine() stopped after ", rounds$runs_added, " runs (`max_runs`) before the ",
              "posterior was resolved, so its intervals show the library's resolution and ",
              "may miss the truth: ", paste0(tab$parameter[bad], " (", why[bad], ")",
                                             collapse = ", "),
              ". Call refine() on the result again, with more `max_runs`.",
              class = c(if (any(drift | thin | open) || !explored(state$problem$library)) "reach",
                        "resolution"))
}
