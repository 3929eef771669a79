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
#' run; a spread one is filled in. When the posterior's 95% interval reaches
#' the outer tenth of the last round's box (and that box stops short of the
#' library's range), the posterior is cut off by where the dense runs end,
#' not by the data: the next box then reaches a whole box width further, so
#' a box that missed the truth finds it in a few rounds.
#'
#' **The prior stays the library's.** A library's equal weights over runs
#' are a uniform prior over \eqn{\theta} only while runs fill the range
#' evenly. Each run of the refined library is therefore weighed by the prior
#' density over the density of the design that produced it (the base
#' library spread over its range plus every round's hypercube over its box),
#' so the prior stays uniform over the library's range. The weights travel
#' with the library: [calibrate()] on it uses them.
#'
#' **Resolved** means that every parameter's marginal posterior spreads
#' over at least 10 effective distinct values (\eqn{1 / \sum_v m_v^2}, the
#' criterion of [summary()][summary.griddy_fit]; for a Gaussian marginal of
#' sd \eqn{s} on runs spaced \eqn{h} apart this is \eqn{3.5 s / h}, so runs
#' at most about a third of a standard deviation apart), that no interval
#' bound moved by more than a fifth of the interval's width in the last
#' round, and that no interval is cut off by the last box (above).
#' `refine()` of a resolved fit returns it unchanged; when `max_runs` runs
#' are spent first, the result warns (class `griddy_warning_resolution`) and
#' `refine()` of it carries on where it stopped.
#'
#' **With a simulator**, new runs are simulated: `simulator(theta, ...)`
#' receives a data.frame of \eqn{\theta} rows (the library's columns) and
#' returns the matrix of their outputs in the library's layout (one row per
#' run, blocks by x setting; see [sim_library()]). The calls are spread over
#' the workers of the user's [future][future::plan] plan when future.apply is
#' installed (a `multisession` plan, or cluster workers through
#' future.batchtools), in chunks, with a progress bar; each chunk gets its
#' own random stream, so a stochastic simulator is reproducible with `seed`.
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
#' @param max_runs The most runs to add, over all rounds.
#' @param ... Further arguments to `simulator`.
#' @param runs_per_round Runs added per round; `NULL` is
#'   \eqn{100 \times 2^{p - 1}} for \eqn{p} varying parameters, at most
#'   `max_runs`.
#' @param seed `NULL`, or a seed for this call only; either way the result is
#'   reproducible with [set.seed()].
#' @param progress Show progress (the simulator's runs and the sampling).
#' @return A `griddy_fit` calibrated on the refined library (a library of
#'   class `refined_library`, usable wherever a library is), with the settings
#'   of `fit` (correlation grids, prior, update, iterations, chains), and an
#'   element `refinement`: a list with `runs_added`, `rounds`, `reason` (why
#'   it stopped: `"resolved"` or `"max_runs"`), `source` (`"simulator"` or
#'   `"emulator"`), `history`, the per-parameter resolution table after
#'   each round, and `emulation_error` (without a simulator; see Details). A fit that is already resolved is returned as it was.
#' @seealso [calibrate()], [summary.griddy_fit()], [posterior_exact()]
#' @references Ritter, C. and Tanner, M. A. (1992). Facilitating the Gibbs
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
refine <- function(fit, simulator = NULL, max_runs = 1000, ..., runs_per_round = NULL,
                   seed = NULL, progress = interactive()) {
  call <- match.call()
  check_refinable(fit)
  if (!is.null(simulator) && !is.function(simulator)) {
    griddy_abort("`simulator` must be NULL or a function of a data.frame of theta rows; ",
                 "received ", class(simulator)[1], ".")
  }
  max_runs <- assert_count(max_runs, "max_runs")
  runs_per_round <- if (is.null(runs_per_round)) {
    min(default_runs_per_round(lib_theta(fit$library)), max_runs)
  } else {
    assert_count(runs_per_round, "runs_per_round")
  }
  seed <- assert_seed(seed)
  progress <- assert_flag(progress, "progress")
  if (!is.null(simulator)) simulator <- simulator_caller(simulator, list(...))
  with_seed(seed, refine_fit(fit, simulator, max_runs, runs_per_round, progress, call))
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

default_runs_per_round <- function(theta) {
  p <- sum(vapply(theta, function(v) max(v) > min(v), logical(1)))
  100L * 2L^(max(p, 1L) - 1L)
}

# The rounds, then one calibration of the refined library with the fit's
# settings.
refine_fit <- function(fit, simulator, max_runs, runs_per_round, progress, call) {
  rounds <- refine_rounds(fit, simulator, max_runs, runs_per_round, progress,
                          previous = unfinished_round(fit))
  if (rounds$runs_added == 0L) {
    cli::cli_inform(c(i = "The posterior is already resolved: nothing to refine."),
                    class = "griddy_message_resolved")
    return(fit)
  }
  out <- sample_problem(rounds$problem, fit$update, fit$control, seed = NULL, call = call)
  out$refinement <- rounds[c("runs_added", "rounds", "reason", "source", "history",
                             "emulation_error")]
  if (rounds$reason != "resolved") warn_unresolved(refine_state(rounds$problem), rounds)
  warn_emulation(rounds$emulation_error)
  out
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

# refine() ran out of runs: say which parameters are not resolved and why.
warn_unresolved <- function(state, rounds) {
  tab <- state$table
  previous <- rounds$history[[max(1L, length(rounds$history) - 1L)]]
  cut <- colSums(truncated_sides(state)) > 0
  moved <- pmax(abs(tab$lower - previous$lower), abs(tab$upper - previous$upper)) >
    interval_tol * pmax(tab$upper - tab$lower, previous$upper - previous$lower)
  why <- ifelse(tab$limited & !tab$constant,
                paste0(format(tab$effective_values, digits = 2), " effective values"),
         ifelse(cut, "its interval reaches the edge of the refined region",
         ifelse(moved, "its interval still moved in the last round", NA)))
  bad <- !is.na(why)
  griddy_warn("refine() stopped after ", rounds$runs_added, " runs (`max_runs`) before the ",
              "posterior was resolved, so its intervals show the library's resolution and ",
              "may miss the truth: ", paste0(tab$parameter[bad], " (", why[bad], ")",
                                             collapse = ", "),
              ". Call refine() on the result again, with more `max_runs`.",
              class = "resolution")
}

# A fit from a refine() that ran out of runs carries on where it stopped: its
# last round is compared with the round before, as if the rounds had not
# been interrupted.
unfinished_round <- function(fit) {
  r <- fit$refinement
  if (is.null(r) || r$reason == "resolved") return(NULL)
  r$history[[max(1L, length(r$history) - 1L)]]
}

# Add runs to a problem (a fit is one) round by round until its posterior is
# resolved or `max_runs` are spent; with `simulator = NULL` the runs are
# predicted from the library. Returns the refined problem, the runs added,
# the number of rounds, why it stopped and the resolution table after each
# round (the first is the problem's own).
refine_rounds <- function(problem, simulator, max_runs, runs_per_round, progress = FALSE,
                          previous = NULL) {
  state <- refine_state(problem)
  history <- list(state$table)
  source <- if (is.null(simulator)) "emulator" else "simulator"
  emulator <- NULL
  added <- 0L
  reason <- "resolved"
  while (!is_resolved(state$table, if (added > 0L) history[[length(history) - 1L]] else
                      previous) ||
         any(truncated_sides(state))) {
    if (added >= max_runs) {
      reason <- "max_runs"
      break
    }
    n_new <- min(runs_per_round, max_runs - added)
    box <- refine_box(state)
    theta_new <- latin_hypercube(n_new, box, names(lib_theta(state$problem$library)))
    if (is.null(simulator)) {
      if (is.null(emulator) || !box_inside(box, emulator$refine_region)) {
        emulator <- round_emulator(state, box)
      }
      batch <- emulated_batch(emulator, theta_new, state)
    } else {
      batch <- list(y = simulator(theta_new, lib_n_out(problem$library), progress),
                    error = NULL, rel_var = NULL)
    }
    round <- list(box = box, n = n_new, source = source, error = batch$error)
    state <- refine_state(extend_problem(state$problem, theta_new, batch$y, round,
                                         batch$rel_var))
    if (is.null(simulator)) state <- restate_noise_var(state)
    added <- added + n_new
    history[[length(history) + 1L]] <- state$table
  }
  list(problem = state$problem, runs_added = added, rounds = length(history) - 1L,
       reason = reason, source = source, history = history,
       emulation_error = if (!is.null(emulator)) emulation_error_ratio(emulator, state))
}

# How well the library predicts its own runs where the posterior is: the
# leave-one-out residuals' root mean square over the 2p + 1 library runs
# nearest the most probable run, over the fitted noise sd. Above 1 the
# predicted runs there are off by more than the noise, and the intervals rest
# on the emulator's error model, an estimate.
emulation_error_ratio <- function(emulator, state) {
  theta <- as.matrix(lib_theta(state$problem$library))
  loo_error_near(emulator, theta[which.max(state$p), ],
                 noise_var_pooled(state$problem, posterior_noise_var(state)))
}

# The root mean square of an emulator's leave-one-out residuals (`loo`, at
# the runs `loo_theta`) over the 2p + 1 runs nearest `mode` (distances on
# columns scaled by the runs' ranges), over the noise sd sqrt(s2).
loo_error_near <- function(emulator, mode, s2) {
  th <- emulator$loo_theta
  width <- pmax(apply(th, 2, function(v) diff(range(v))), 1e-300)
  d2 <- colSums(((t(th) - mode) / width)^2)
  near <- order(d2)[seq_len(min(2L * ncol(th) + 1L, length(d2)))]
  sqrt(mean(emulator$loo[near, ]^2) / s2)
}

# One noise variance for all observed points: the groups' own (see
# posterior_noise_var()) averaged over the points.
noise_var_pooled <- function(problem, s2) {
  sum(s2 * problem$setup$group_sizes) / sum(problem$setup$group_sizes)
}

# The exact posterior over runs of a problem and its resolution table.
refine_state <- function(problem) {
  post <- grid_posterior(problem)
  p <- post$run
  list(problem = problem, joint = post$joint, p = p,
       table = resolution_table(p, lib_theta(problem$library)))
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

# ---- where the new runs go -------------------------------------------------------

# The box of the marginal posteriors' central 99%, widened on each side by
# the local spacing around the most probable run or a quarter of its width,
# whichever is larger, inside the base library's range. (Central quantiles,
# not the runs holding 99.9% of the mass: with few data the posterior's
# tails are long, and a box around all of them spreads each round's runs
# over the whole range. The tails keep the runs of earlier rounds.) A box only as wide
# as the posterior's runs would cut off what the last round's runs could not
# reach, and keep cutting it off; widening by a share of the width lets a
# truncated posterior grow its box by half each round until it is whole.
box_margin <- 0.25

refine_box <- function(state) {
  library <- state$problem$library
  theta <- as.matrix(lib_theta(library))
  range0 <- library_box(if (inherits(library, "refined_library")) library$base else library)
  bounds <- apply(theta, 2, weighted_quantile, w = state$p, probs = c(0.005, 0.995))
  lower <- bounds[1, ]
  upper <- bounds[2, ]
  margin <- pmax(local_spacing(theta, which.max(state$p), range0), box_margin * (upper - lower))
  # a posterior cut off by the last round's box reaches for a whole box
  # width beyond it, so a box that missed the truth finds it in a few rounds
  cut <- truncated_sides(state)
  if (any(cut)) {
    last <- last_box(library)
    width <- last[2, ] - last[1, ]
    lower[cut[1, ]] <- pmin(lower, last[1, ] - width)[cut[1, ]]
    upper[cut[2, ]] <- pmax(upper, last[2, ] + width)[cut[2, ]]
  }
  rbind(pmax(lower - margin, range0[1, ]), pmin(upper + margin, range0[2, ]))
}

# Sides (rows lower, upper; one column per parameter) on which the
# posterior's 95% interval reaches the outer tenth of the last round's box
# while the box stops short of the library's range: there the dense runs
# end, and the posterior is cut off by them rather than by the data.
truncated_sides <- function(state) {
  library <- state$problem$library
  p <- ncol(lib_theta(library))
  last <- last_box(library)
  if (is.null(last)) return(matrix(FALSE, 2, p))
  range0 <- library_box(library$base)
  band <- edge_band * (last[2, ] - last[1, ])
  tab <- state$table
  rbind(tab$lower <= last[1, ] + band & last[1, ] > range0[1, ] & band > 0,
        tab$upper >= last[2, ] - band & last[2, ] < range0[2, ] & band > 0)
}

edge_band <- 0.1

last_box <- function(library) {
  if (!inherits(library, "refined_library") || length(library$rounds) == 0L) return(NULL)
  library$rounds[[length(library$rounds)]]$box
}

# The library's spacing around run `centre`, per parameter: the spread of
# the 2p runs nearest it (distances on columns scaled by the library's
# range), the typical gap of a scattered design; and at least the gap to the
# next distinct value of the column on either side, one step of a grid even
# when the nearest runs all lie along other axes.
local_spacing <- function(theta, centre, range0) {
  width <- range0[2, ] - range0[1, ]
  varies <- width > 0
  scaled <- sweep(theta[, varies, drop = FALSE], 2, width[varies], "/")
  d2 <- colSums((t(scaled) - scaled[centre, ])^2)
  near <- order(d2)[seq_len(min(2L * sum(varies) + 1L, nrow(theta)))]
  spacing <- numeric(ncol(theta))
  spacing[varies] <- apply(abs(sweep(theta[near, varies, drop = FALSE], 2,
                                     theta[centre, varies], "-")), 2, max)
  for (j in which(varies)) {
    gaps <- abs(unique(theta[, j]) - theta[centre, j])
    spacing[j] <- max(spacing[j], min(gaps[gaps > 1e-9 * width[j]]))
  }
  spacing
}

box_inside <- function(box, region) {
  all(box[1, ] >= region[1, ]) && all(box[2, ] <= region[2, ])
}

# n runs in `box` by a Latin hypercube (one run in each of n equal slices of
# every parameter, at a uniform place in its slice), from R's random stream.
latin_hypercube <- function(n, box, names) {
  u <- vapply(seq_len(ncol(box)), function(j) (sample.int(n) - stats::runif(n)) / n,
              numeric(n))
  u <- matrix(u, n, ncol(box))
  theta <- sweep(sweep(u, 2, box[2, ] - box[1, ], "*"), 2, box[1, ], "+")
  stats::setNames(as.data.frame(theta), names)
}

# ---- new runs into the problem -------------------------------------------------

# The problem with runs added: their quadratic forms appended to C, every
# run's prior weight recomputed for the new design.
extend_problem <- function(problem, theta_new, y_new, round, rel_var) {
  library <- add_runs(problem$library, theta_new, y_new, round, rel_var)
  n_added <- nrow(library$added$y)
  which <- seq(n_added - nrow(theta_new) + 1L, n_added)
  C_new <- fold_extra_logdet(added_quad_forms(library, which, problem$y_field, problem$setup),
                             problem$prior, problem$n_obs)
  problem_from_parts(library, problem$y_field, problem$prior, lib_log_prior(library),
                     problem$setup, C = rbind(problem$C, C_new))
}

# ---- runs from the simulator -------------------------------------------------------

# A function(theta, n_out, progress) that runs the user's simulator over the
# rows of theta in chunks, on the future plan's workers when there are any,
# and checks what comes back.
#
# Each chunk runs with its own seed, that of its first row among seeds drawn
# for every row from R's stream, so the stream moves on by the same amount
# under any plan, and a deterministic simulator gives the same library under
# any plan (a stochastic one, under plans with the same number of workers).
simulator_caller <- function(simulator, dots) {
  force(simulator)
  function(theta, n_out, progress) {
    chunks <- simulator_chunks(nrow(theta))
    seeds <- sample.int(.Machine$integer.max, nrow(theta))
    bar <- if (progress) cli::cli_progress_bar("Simulating", total = nrow(theta),
                                               .envir = environment())
    call_chunk <- function(rows) {
      with_seed(seeds[rows[1]], do.call(simulator, c(list(theta[rows, , drop = FALSE]), dots)))
    }
    map <- simulator_map()
    out <- vector("list", length(chunks))
    for (wave in split(seq_along(chunks), (seq_along(chunks) - 1L) %/% map$per_wave)) {
      out[wave] <- map$apply(chunks[wave], call_chunk)
      if (progress) cli::cli_progress_update(inc = sum(lengths(chunks[wave])), id = bar)
    }
    do.call(rbind, Map(check_simulated, out, chunks, MoreArgs = list(theta = theta,
                                                                     n_out = n_out)))
  }
}

# Chunks of rows: about four per worker, and at least ten for the progress
# bar, so a slow run holds up little.
simulator_chunks <- function(n) {
  workers <- if (parallel_plan()) future::nbrOfWorkers() else 1L
  k <- min(n, max(10L, 4L * workers))
  unname(split(seq_len(n), cut(seq_len(n), k, labels = FALSE)))
}

simulator_map <- function() {
  if (parallel_plan()) {
    list(per_wave = future::nbrOfWorkers(),
         apply = function(x, f) {
           future.apply::future_lapply(x, f, future.seed = NULL, future.packages = "griddy")
         })
  } else {
    list(per_wave = 1L, apply = function(x, f) lapply(x, f))
  }
}

check_simulated <- function(y, rows, theta, n_out) {
  if (is.numeric(y) && is.null(dim(y)) && length(rows) == 1L) y <- matrix(y, 1L)
  if (!is.matrix(y) || !is.numeric(y) || nrow(y) != length(rows) || ncol(y) != n_out) {
    griddy_abort("`simulator` must return a numeric matrix with one row per theta row and ",
                 n_out, " columns (the library's outputs); for rows ",
                 show_some(rows), " it returned ",
                 if (is.matrix(y)) paste0("a ", nrow(y), " x ", ncol(y), " ", typeof(y),
                                          " matrix") else class(y)[1], ".", class = "shape")
  }
  if (!all(is.finite(y))) {
    bad <- rows[!apply(is.finite(y), 1, all)]
    griddy_abort("`simulator` returned non-finite outputs for theta ",
                 paste0(names(theta), " = ", format(unlist(theta[bad[1], ]), digits = 4),
                        collapse = ", "), " (", length(bad), " run(s)).", class = "numeric")
  }
  storage.mode(y) <- "double"
  y
}

# ---- runs from the library itself -------------------------------------------------------

# The emulator of a round: built from the library's simulated runs over a
# region that leaves room for the boxes of later rounds (half the box's
# width on each side, inside the library's range).
round_emulator <- function(state, box) {
  library <- state$problem$library
  # an emulated library predicts with its own emulator of the design runs,
  # not one of its predicted runs
  base <- if (inherits(library, "refined_library")) library$base else library
  if (inherits(base, "emulated_library")) return(emulated_round_emulator(base))
  source <- simulated_runs(library)
  range0 <- library_box(source)
  pad <- (box[2, ] - box[1, ]) / 2
  region <- rbind(pmax(box[1, ] - pad, range0[1, ]), pmin(box[2, ] + pad, range0[2, ]))
  emulator <- library_emulator(source, region = as.data.frame(region))
  loo <- emulator_loo(emulator)
  if (!all(is.finite(loo$residuals))) {
    # a Gaussian process too near singular to predict its own runs: the
    # local fit does
    emulator <- library_emulator(source, region = as.data.frame(region), method = "local")
    loo <- emulator_loo(emulator)
  }
  emulator$refine_region <- region
  emulator$loo <- loo$residuals
  emulator$loo_theta <- as.matrix(lib_theta(source)[loo$rows, , drop = FALSE])
  emulator
}

# The runs of a library that were simulated (not predicted): the library
# itself, the base of a refined library, or those with the runs a simulator
# added.
simulated_runs <- function(library) {
  if (!inherits(library, "refined_library")) return(library)
  simulated <- which(library$added$rel_var == 0 & vapply(
    library$added$round, function(r) is.null(library$rounds[[r]]$error), logical(1)))
  if (length(simulated) == 0L) return(library$base)
  rows <- c(seq_len(lib_n_runs(library$base)), lib_n_runs(library$base) + simulated)
  sim_library(lib_theta(library)[rows, , drop = FALSE], lib_outputs(library, rows),
              x = lib_x(library), t = lib_t(library))
}

# Predicted outputs, their relative variances and the round's error model
# (on the scale of the round's posterior mean noise variance).
emulated_batch <- function(emulator, theta_new, state) {
  if (identical(emulator$method, "emulated_library")) {
    return(emulated_library_batch(emulator$library, theta_new, posterior_noise_var(state)))
  }
  pred <- emulator_predict(emulator, theta_new)
  list(y = pred$outputs, rel_var = pred$rel_var,
       error = emulation_error_model(emulator$loo, posterior_noise_var(state)))
}

# Every round's prediction error on the scale of the current posterior's
# noise variance, and the posterior again. The scale is a plug-in; the first
# rounds' posteriors, still on a coarse library, overstate the noise by the
# library's misfit, which would understate the prediction error relative to
# it; so each round puts all rounds on the newest estimate, a few times, to
# a fixed point. An emulated base library's runs are restated with them.
restate_noise_var <- function(state, times = 3L) {
  for (i in seq_len(times)) {
    problem <- state$problem
    library <- problem$library
    s2 <- posterior_noise_var(state)
    emulated <- which(vapply(library$rounds, function(r) !is.null(r$error), logical(1)))
    base_emulated <- inherits(library$base, "emulated_library")
    if (length(emulated) == 0L && !base_emulated) return(state)
    old <- vapply(library$rounds[emulated], function(r) r$error$noise_var, s2)
    if (base_emulated) {
      # one value per noise group, as posterior_noise_var() gives
      base_s2 <- library$base$noise$noise_var
      old <- c(old, if (length(base_s2) == length(s2)) base_s2 else rep(NA_real_, length(s2)))
    }
    if (all(!is.na(old) & abs(old - s2) <= 0.01 * s2)) return(state)
    if (base_emulated) {
      library$base$noise <- list(y_field = problem$y_field, noise_var = s2)
      problem$C[seq_len(lib_n_runs(library$base)), ] <- fold_extra_logdet(
        emulated_library_forms(library$base, problem$y_field, problem$setup, s2),
        problem$prior, problem$n_obs)
    }
    for (r in emulated) library$rounds[[r]]$error$noise_var <- s2
    which <- which(library$added$round %in% emulated)
    rows <- lib_n_runs(library$base) + which
    if (length(which) > 0L) {
      problem$C[rows, ] <- fold_extra_logdet(
        added_quad_forms(library, which, problem$y_field, problem$setup),
        problem$prior, problem$n_obs)
    }
    problem$library <- library
    state <- refine_state(problem)
  }
  state
}

# The posterior mean of 1/tau: (b + C/2) / (a + n/2 - 1) averaged over the
# exact posterior over (run, grid point); with noise groups, that of each
# 1/tau_k (over the runs that carry the posterior: all but 1e-12 of it).
posterior_noise_var <- function(state) {
  pr <- state$problem
  sizes <- pr$setup$group_sizes
  denom <- pmax(pr$prior$shape + sizes / 2 - 1, 0.5)
  if (length(sizes) == 1L) {
    # column by column: no temporaries as large as C (8 GB at 10^6 runs x 1,000 grid points)
    weighted_C <- sum(vapply(seq_len(ncol(pr$C)), function(g) sum(state$joint[, g] * pr$C[, g]),
                             numeric(1)))
    return((pr$prior$rate * sum(state$joint) + weighted_C / 2) / denom)
  }
  total <- numeric(length(sizes))
  for (g in seq_len(ncol(state$joint))) {
    runs <- which(state$joint[, g] > 1e-12 * max(state$joint))
    if (length(runs) == 0L) next
    Ck <- run_group_forms(pr, runs, g)
    total <- total + colSums(state$joint[runs, g] * (pr$prior$rate + Ck / 2))
  }
  total / sum(state$joint) / denom
}
