#' Settings shared by the calibrating functions
#'
#' One object for the settings that [calibrate()], [refine()],
#' [diagnose_gap()] and [koh_calibrate()] share: how long a chain runs, how
#' many runs a refinement may add, and whether to show progress. Each of those
#' functions takes it as `control` and also keeps the settings as arguments of
#' their own, whose defaults are read from `control`: an argument given in the
#' call wins, and everything else comes from one place, so the four functions
#' cannot drift apart. Every setting is checked here, once.
#'
#' @param n_iter Iterations per chain, the burn-in included (the thesis ran
#'   35,000).
#' @param burn_in Iterations dropped from the start of each chain (15,000 in
#'   the thesis).
#'
#'   **Sized to the problem.** When neither `n_iter` nor `burn_in` is given
#'   (here or to [calibrate()]), a collapsed-update [calibrate()] first runs
#'   each chain for 5,000 iterations, 1,000 of them burn-in, and keeps that
#'   run when its draws pass the convergence checks (see [calibrate()]) with
#'   at least 400 effective draws of the run index; otherwise it runs the
#'   chains again for `n_iter` and `burn_in` (the thesis's 35,000 and
#'   15,000). With one correlation grid point the collapsed update draws
#'   every iteration independently from the exact posterior, so 4,000 kept
#'   draws are 4,000 independent ones, the number Stan's default run keeps.
#'   The fit's `control` holds the length that ran. The thesis's update, and
#'   every other function, runs `n_iter` and `burn_in` as they are.
#' @param thin Keep every `thin`-th draw after the burn-in.
#' @param chains Number of chains; under a parallel `future` plan they run on
#'   its workers.
#' @param max_runs The most runs a refinement ([refine()], and the matched
#'   refinements inside [diagnose_gap()]) may add. The default resolved the
#'   2- and 3-parameter problems we measured (see [refine()]).
#' @param runs_per_round Runs added per refinement round; `NULL` chooses from
#'   the number of parameters (see [refine()]).
#' @param progress Show progress bars (`cli`) for long computations.
#' @return A list of class `griddy_control` with the validated settings, as
#'   whole numbers and a flag.
#' @seealso [calibrate()], [refine()], [diagnose_gap()], [koh_calibrate()].
#' @examples
#' control <- griddy_control(n_iter = 4000, burn_in = 1000, chains = 2)
#' control
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, control = control, seed = 1)
#' fit$control$n_iter
#' @export
griddy_control <- function(n_iter = 35000, burn_in = 15000, thin = 1, chains = 1,
                           max_runs = 4000, runs_per_round = NULL,
                           progress = interactive()) {
  sized <- missing(n_iter) && missing(burn_in)
  sampling <- sampler_settings(n_iter, burn_in, thin, chains)
  structure(
    c(sampling, list(sized = sized),
      list(max_runs = assert_count(max_runs, "max_runs"),
           runs_per_round = if (!is.null(runs_per_round)) {
             assert_count(runs_per_round, "runs_per_round")
           },
           progress = assert_flag(progress, "progress"))),
    class = "griddy_control"
  )
}

# The chain settings, checked together: the burn-in must leave draws to keep.
sampler_settings <- function(n_iter, burn_in, thin, chains) {
  n_iter <- assert_count(n_iter, "n_iter")
  burn_in <- assert_count(burn_in, "burn_in", min = 0L)
  thin <- assert_count(thin, "thin")
  chains <- assert_count(chains, "chains")
  if (burn_in >= n_iter) {
    griddy_abort("`burn_in` (", burn_in, ") must be smaller than `n_iter` (", n_iter, ").")
  }
  if (thin > n_iter - burn_in) {
    griddy_abort("`thin` (", thin, ") keeps no draw of the ", n_iter - burn_in,
                 " after the burn-in.")
  }
  list(n_iter = n_iter, burn_in = burn_in, thin = thin, chains = chains)
}

# `control` as an exported function receives it: a griddy_control.
assert_control <- function(control) {
  if (!inherits(control, "griddy_control")) {
    griddy_abort("`control` must come from griddy_control(); received ", class(control)[1],
                 ".")
  }
  control
}

#' @export
print.griddy_control <- function(x, ...) {
  cat("<griddy_control>\n")
  cat("  chains:     ", x$chains, " x ", format(x$n_iter, big.mark = ","),
      " iterations, ", format(x$burn_in, big.mark = ","), " burn-in, thin ", x$thin, "\n",
      sep = "")
  if (isTRUE(x$sized)) {
    cat("              (calibrate(): ", format(sized_chain$n_iter, big.mark = ","), " and ",
        format(sized_chain$burn_in, big.mark = ","), " while the chains settle)\n", sep = "")
  }
  cat("  refinement: at most ", format(x$max_runs, big.mark = ","), " runs, ",
      if (is.null(x$runs_per_round)) "runs per round by the number of parameters" else
        paste(x$runs_per_round, "per round"), "\n", sep = "")
  cat("  progress:   ", x$progress, "\n", sep = "")
  invisible(x)
}
