#' Summarise a griddy fit
#'
#' One row per sampled parameter (each \eqn{\theta} column, `tau` or each
#' noise group's `tau_<label>`, each
#' correlation parameter), with checks of whether the library is fine and wide
#' enough for the posterior. They use the exact posterior over runs (see
#' [posterior_exact()]):
#'
#' * **Resolution.** For each \eqn{\theta} parameter, the effective number of
#'   distinct library values that carry its marginal, \eqn{1 / \sum_v m_v^2}
#'   over the marginal masses \eqn{m_v}. Below 10 the parameter is
#'   `"limited"`: its interval shows the library's spacing, not the data's
#'   uncertainty, and may miss a truth between runs; add runs where the
#'   posterior has its mass (see `?refine`). For a Gaussian marginal of sd
#'   \eqn{s} on a grid of step \eqn{h} the effective number is about
#'   \eqn{3.5 s / h}, so 10 values mean a step below about \eqn{s / 3}.
#' * **Range.** The posterior mass on each parameter's minimum and maximum in
#'   the library; above 5% the truth may lie outside the library's range.
#' * **Runs.** The effective number of runs (\eqn{1 / \sum p_i^2}), and the
#'   total-variation distance between the sampled and the exact posterior
#'   over runs.
#'
#' Bounds are quantiles of the draws (type 1, so for \eqn{\theta} they are
#' library values). `ess` is [coda::effectiveSize()] summed over chains;
#' `rhat` is [coda::gelman.diag()]'s point estimate, `NA` with one chain or a
#' constant parameter.
#'
#' @param object,x A `griddy_fit` from [calibrate()], or its summary.
#' @param level Probability of the central interval.
#' @param digits Significant digits to print.
#' @param ... Ignored.
#' @return `summary()`: a data.frame of class `griddy_summary` with columns
#'   `parameter`, `mean`, `median`, `lower`, `upper`, `ess`, `rhat` and
#'   `resolution` (`"resolved"` or `"limited"` for each \eqn{\theta}
#'   parameter, `NA` for the others). Attribute `"adequacy"` holds the checks:
#'   `parameters`, a data.frame with one row per \eqn{\theta} parameter and
#'   columns `parameter`, `lower` and `upper` (the interval of the exact
#'   marginal, over library values), `effective_values`,
#'   `distinct_in_interval` (distinct values with positive mass in the
#'   interval), `limited`, `mass_at_min`, `mass_at_max` and `library_values`
#'   (distinct values in the library); `effective_runs` (exact) and
#'   `effective_runs_sampled`; `tv_distance`; and `emulation_error`, for a
#'   library whose runs were predicted by an emulator ([emulated_library()],
#'   or [refine()] without a simulator), the emulator's leave-one-out error
#'   near the posterior over the noise sd (`NULL` when every run was
#'   simulated). `print()` prints the
#'   table, then one line per limited parameter and per parameter with mass at
#'   the edge of its range, and returns its argument invisibly.
#' @examples
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 1000, burn_in = 200,
#'                  chains = 2, seed = 1)
#' s <- summary(fit)
#' s
#' s[s$parameter == "k", c("lower", "upper")]
#' @export
summary.griddy_fit <- function(object, level = 0.95, ...) {
  assert_level(level)
  draws <- parameter_draws(object)
  tail <- (1 - level) / 2
  rows <- lapply(names(draws), function(p) {
    v <- draws[[p]]
    q <- stats::quantile(v, c(tail, 0.5, 1 - tail), type = 1, names = FALSE)
    data.frame(parameter = p, mean = mean(v), median = q[2], lower = q[1], upper = q[3],
               chain_diagnostics(chain_matrix(v, object$draws$chain)))
  })
  out <- do.call(rbind, rows)
  adequacy <- library_adequacy(object, level)
  tab <- adequacy$parameters
  out$resolution <- ifelse(tab$limited, "limited", "resolved")[match(out$parameter,
                                                                     tab$parameter)]
  structure(out, class = c("griddy_summary", "data.frame"),
            adequacy = adequacy, level = level,
            info = fit_description(object))
}

fit_description <- function(fit) {
  ctrl <- fit$control
  paste0("Griddy Gibbs (", fit$update, " update) over ", lib_n_runs(fit$library),
         " runs x ", nrow(fit$grid), " correlation grid point(s); ", fit$n_obs,
         " data points", missing_description(fit), "; ", ctrl$chains, " chain(s) x ", ctrl$n_iter, " iterations (burn-in ",
         ctrl$burn_in, ", thin ", ctrl$thin, "); ",
         format(sum(fit$runtime), digits = 3), " s", refinement_description(fit$refinement))
}

missing_description <- function(fit) {
  n_miss <- sum(is.na(fit$y_field))
  n_cells <- length(fit$y_field) - n_miss
  groups <- length(fit$setup$group_sizes)
  paste0(if (fit$n_obs > n_cells) paste0(" at ", n_cells, " measured cells (replicates)"),
         if (n_miss > 0L) paste0(" (", n_miss, " missing)"),
         if (groups > 1L) paste0(" in ", groups, " noise groups"))
}

refinement_description <- function(refinement) {
  if (is.null(refinement)) return("")
  paste0("\nRefined: ", refinement$runs_added, " ", refinement$source, " run(s) added in ",
         refinement$rounds, " round(s); stopped: ",
         if (refinement$reason == "resolved") "resolved" else "max_runs reached")
}

#' @rdname summary.griddy_fit
#' @export
print.griddy_summary <- function(x, digits = 4, ...) {
  cli::cat_line(attr(x, "info"))
  level <- if (is.null(attr(x, "level"))) 0.95 else attr(x, "level")
  tab <- as.data.frame(x)
  class(tab) <- "data.frame"
  if (!is.null(tab$resolution)) tab$resolution[is.na(tab$resolution)] <- ""
  bounds <- names(tab) %in% c("lower", "upper")
  names(tab)[bounds] <- paste0(names(tab)[bounds], " (", format(100 * level), "%)")
  print(tab, digits = digits, row.names = FALSE)
  adequacy <- attr(x, "adequacy")
  if (!is.null(adequacy)) cli::cat_line(format_adequacy(adequacy))
  if (!is.null(tab$rhat) && !is.null(adequacy$tv_reference)) {
    problems <- convergence_problems(stats::setNames(tab$rhat, tab$parameter),
                                     adequacy$tv_distance, adequacy$tv_reference)
    notes <- format_convergence(problems, adequacy$tv_distance, adequacy$tv_reference)
    if (length(notes) > 0L) cli::cat_line(paste("Convergence:", notes))
  }
  invisible(x)
}

#' @rdname summary.griddy_fit
#' @export
print.griddy_fit <- function(x, digits = 4, ...) {
  print(summary(x), digits = digits)
  invisible(x)
}
