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
#'   over runs, beside what Monte Carlo error alone would give: its expected
#'   value for independent draws from the exact posterior, as many as the
#'   draws' effective number \eqn{m}, \eqn{\frac{1}{2}\sum_i E|X_i/m - p_i|}
#'   with \eqn{X_i \sim Binomial(m, p_i)} (exact, by De Moivre's formula;
#'   about \eqn{\frac{1}{2}\sum_i \sqrt{2 p_i (1 - p_i) / (\pi m)}} when
#'   every \eqn{m p_i} is large). The effective number \eqn{m} of the run
#'   index is the smallest bulk ESS of the drawn run's exact log probability
#'   and of each \eqn{\theta} column, at most the number of draws (all the
#'   draws when none of them moves). A distance more than 3 times the
#'   reference and above 0.05 is noted, and [calibrate()] warns.
#'
#' Bounds are quantiles of the draws (type 1, so for \eqn{\theta} they are
#' library values). The chain diagnostics are the rank-normalised ones of
#' Vehtari et al. (2021), from the \pkg{posterior} package, over all chains:
#' the bulk and tail effective sample sizes `ess_bulk`
#' ([posterior::ess_bulk()]) and `ess_tail` ([posterior::ess_tail()]),
#' `rhat` ([posterior::rhat()], over chains split in halves, so one chain has
#' one too; `Inf` when every chain half sits on one value but they differ)
#' and `mcse` ([posterior::mcse_mean()]), the Monte Carlo standard error of
#' the mean. All four are `NA` for a parameter whose kept draws are all one
#' value. `ess_tail` alone is `NA` when the 95% quantile of the draws is
#' their largest value, as when the largest library value drawn holds at
#' least 5% of a discrete posterior: the tail ESS measures how well the
#' chains place the 5% and 95% quantiles through the indicator of the draws
#' at or below each, and that indicator is then constant (`print()` says so
#' below the table). An R-hat above 1.01 is noted, and [calibrate()] warns. A discrete
#' parameter that seldom changes value can still have a large ESS: the ESS
#' is about its mean, and says nothing of the library's resolution (see
#' above). [coda::as.mcmc.list()] gives the draws to coda.
#'
#' @param object,x A `griddy_fit` from [calibrate()], or its summary.
#' @param level Probability of the central interval.
#' @param digits Significant digits to print, per parameter: each row's
#'   estimate and bounds are formatted on that parameter's own scale.
#' @param width Width of the printed lines: the header and notes wrap, and
#'   the table's columns continue below.
#' @param ... Ignored.
#' @return `summary()`: a data.frame of class `griddy_summary` with columns
#'   `parameter`, `estimate`, `estimate_type`, `mean`, `median`, `lower`,
#'   `upper`, `ess_bulk`,
#'   `ess_tail`, `rhat`, `mcse` and `resolution` (`"resolved"` or `"limited"` for each \eqn{\theta}
#'   parameter, `NA` for the others). Attribute `"adequacy"` holds the checks:
#'   `parameters`, a data.frame with one row per \eqn{\theta} parameter and
#'   columns `parameter`, `lower` and `upper` (the interval of the exact
#'   marginal, over library values), `effective_values`,
#'   `distinct_in_interval` (distinct values with positive mass in the
#'   interval), `limited`, `mass_at_min`, `mass_at_max` and `constant`
#'   (`TRUE` when the library holds the parameter at one value); `effective_runs` (exact) and
#'   `effective_runs_sampled`; `tv_distance`, `tv_reference` (its Monte
#'   Carlo reference) and `effective_draws` (the effective number of draws of
#'   the run index it uses); and `emulation_error`, for a
#'   library whose runs were predicted by an emulator ([emulated_library()],
#'   or [refine()] without a simulator), the emulator's leave-one-out error
#'   near the posterior over the noise sd (`NULL` when every run was
#'   simulated). `estimate` is the posterior mean where it lies within
#'   \[`lower`, `upper`\] (`estimate_type` `"mean"`), otherwise the median
#'   (`"median"`). A discrete posterior can put its mean outside its own
#'   interval: with most of the mass on one library value and the rest on
#'   values far off, the interval is that one value and the mean lies beside
#'   it; the median is then a library value inside the interval, where the
#'   mean is not. [coef()][coef.griddy_fit] and [tidy()][tidy.griddy_fit]
#'   give this same estimate by default. `print()` prints the
#'   table (the estimate, marked `*` where it is the median, the interval's
#'   bounds named by their probabilities, and the diagnostics; `mean` and
#'   `median` stay in the data.frame) and a line saying which estimate is
#'   reported, then one line per limited parameter and per parameter with mass at
#'   the edge of its range, for a fit with a discrepancy a "Discrepancy:" line
#'   (its Bayes factor, where a gap lies, and in one sentence what
#'   \eqn{\theta} estimates under it: see "What theta means" in
#'   [gp_discrepancy()]), then a "Convergence:" note for an R-hat above
#'   1.01 and for a total-variation distance beyond Monte Carlo error, and
#'   returns its argument invisibly.
#' @references Vehtari, A., Gelman, A., Simpson, D., Carpenter, B. and
#'   Buerkner, P.-C. (2021). Rank-normalization, folding, and localization: an
#'   improved R-hat for assessing convergence of MCMC. *Bayesian Analysis*
#'   16(2), 667-718. \doi{10.1214/20-BA1221}
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
  out <- draws_summary(parameter_draws(object), object$draws$chain, level, type = 1,
                       known = stored_diagnostics(object))
  adequacy <- library_adequacy(object, level)
  tab <- adequacy$parameters
  out$resolution <- ifelse(tab$limited, "limited", "resolved")[match(out$parameter,
                                                                     tab$parameter)]
  structure(out, class = c("griddy_summary", "data.frame"),
            adequacy = adequacy, level = level,
            info = fit_description(object), discrepancy = fit_discrepancy_evidence(object),
            estimand = theta_estimand(object$setup$discrepancy),
            gap_screen = if (screen_shows_gap(object) || screen_unweighable(object) &&
                               is.null(object$setup$discrepancy)) object$gap_screen,
            library_x = lib_x(object$library))
}

# The discrepancy evidence of a fit with one to weigh, else NULL.
fit_discrepancy_evidence <- function(fit) {
  if (is.null(fit$setup$discrepancy)) return(NULL)
  ev <- tryCatch(discrepancy_evidence(fit), griddy_error_input = function(e) NULL)
  if (is.null(ev)) return(NULL)
  # the warning's rule and words (warn_gap()): the base model's block checks count
  blocks <- fit$gap_screen$blocks
  ev$n_flagged <- if (is.null(blocks)) 0L else sum(blocks$flagged)
  local <- local_misfit_text(blocks, fit$library)
  if (gap_shown(ev$log_bayes_factor, ev$n_flagged)) {
    ev$where <- paste(c(if (!is.null(local)) paste0(toupper(substr(local, 1, 1)),
                                                     substring(local, 2), "."),
                        discrepancy_where_text(fit)), collapse = " ")
  }
  ev$unweighable <- screen_unweighable(fit)
  ev
}

# summary()'s line on the gap screen of a fit without a discrepancy, when it
# found a gap (screen_shows_gap(), the warning's rule and words).
format_gap_screen <- function(screen, library = NULL) {
  if (isFALSE(screen$weighable)) return(paste0("Gap: griddy ", gap_unweighable_sentence, "."))
  if (is.null(screen) || !gap_shown(screen$log_bf, screen$n_flagged)) return(character())
  paste("Gap:", gap_screen_message(screen, library))
}

# summary()'s line on the discrepancy: the Bayes factor, where a gap lies
# when it shows one, and what theta estimates (theta_estimand(), `estimand`;
# stated whatever the evidence, as the fit's intervals are of that theta).
format_discrepancy <- function(ev, estimand = NULL) {
  if (is.null(ev) && is.null(estimand)) return(character())
  evidence <- if (!is.null(ev)) {
    paste0(" log Bayes factor ", format(ev$log_bayes_factor, digits = 3), " (",
           evidence_words(ev$log_bayes_factor), "); posterior probability of none ",
           format(ev$prob_none, digits = 3), ".",
           if (isTRUE(ev$unweighable)) {
             paste0(" griddy ", gap_unweighable_sentence, ".")
           } else if (gap_shown(ev$log_bayes_factor, ev$n_flagged)) {
             paste(" The data show a gap.", ev$where)
           })
  }
  paste0("Discrepancy:", evidence, if (!is.null(estimand)) paste0(" ", estimand))
}

# summary()'s rows for a data.frame of draws (one column per parameter) from
# the chains `chain`: the estimates and interval of draws_estimates() and the
# chain diagnostics, with the R-hat and bulk ESS in `known` (a fit's stored
# diagnostics, fit_diagnostics(): named vectors `rhat` and `ess_bulk`) taken
# from there.
draws_summary <- function(draws, chain, level, type, known = NULL) {
  do.call(rbind, lapply(names(draws), function(p) {
    v <- draws[[p]]
    data.frame(parameter = p, draws_estimates(v, level, type),
               chain_diagnostics(chain_matrix(v, chain), rhat = value_of(known$rhat, p),
                                 ess_bulk = value_of(known$ess_bulk, p)))
  }))
}

# The element `name` of a named vector, NULL when it has none.
value_of <- function(x, name) if (name %in% names(x)) x[[name]] else NULL

# The point estimates and central interval (quantiles of `type`) of one
# parameter's draws. `estimate` is the mean, unless the mean lies outside the
# interval, which a discrete posterior allows (most of its mass on one library
# value, the rest far off): then the median, a value inside it.
draws_estimates <- function(v, level, type) {
  tail <- (1 - level) / 2
  q <- stats::quantile(v, c(tail, 0.5, 1 - tail), type = type, names = FALSE)
  m <- mean(v)
  # a constant parameter's mean can differ from its value by rounding
  slack <- sqrt(.Machine$double.eps) * max(abs(q[c(1, 3)]))
  inside <- q[1] - slack <= m && m <= q[3] + slack
  data.frame(estimate = if (inside) m else q[2], estimate_type = if (inside) "mean" else "median",
             mean = m, median = q[2], lower = q[1], upper = q[3])
}

fit_description <- function(fit) {
  ctrl <- fit$control
  paste0("Griddy Gibbs (", fit$update, " update) over ", lib_n_runs(fit$library),
         " runs x ", nrow(fit$grid), " correlation grid point(s); ", fit$n_obs,
         " data points", missing_description(fit), "; ", ctrl$chains, " chain(s) x ", ctrl$n_iter, " iterations (burn-in ",
         ctrl$burn_in, ", thin ", ctrl$thin, "); ",
         runtime_description(fit$runtime), "\nMemory: ",
         memory_statement(fit$library, nrow(fit$grid), fit$update),
         refinement_description(fit$refinement))
}

# The whole call's time, then its parts (those of an older fit: precompute
# and sampling only).
runtime_description <- function(runtime) {
  paste0(format(sum(runtime), digits = 3), " s in all (",
         paste(names(runtime), vapply(runtime, format, "", digits = 2), collapse = ", "), ")")
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
print.griddy_summary <- function(x, digits = 4, width = getOption("width"), ...) {
  # a subset of the rows or columns has lost the attributes
  if (!is.null(attr(x, "info"))) cat_wrapped(strsplit(attr(x, "info"), "\n")[[1]], width)
  level <- if (is.null(attr(x, "level"))) 0.95 else attr(x, "level")
  print_summary_table(x, digits, width, level)
  adequacy <- attr(x, "adequacy")
  if (!is.null(adequacy)) cat_wrapped(format_adequacy(adequacy), width)
  cat_wrapped(format_discrepancy(attr(x, "discrepancy"), attr(x, "estimand")), width)
  cat_wrapped(format_gap_screen(attr(x, "gap_screen"), list(x = attr(x, "library_x"))),
              width)
  if (!is.null(x$rhat) && !is.null(adequacy$tv_reference)) {
    problems <- convergence_problems(stats::setNames(x$rhat, x$parameter),
                                     adequacy$tv_distance, adequacy$tv_reference)
    notes <- format_convergence(problems, adequacy$tv_distance, adequacy$tv_reference)
    if (length(notes) > 0L) cat_wrapped(paste("Convergence:", notes), width)
  }
  invisible(x)
}

#' @rdname summary.griddy_fit
#' @export
print.griddy_fit <- function(x, digits = 4, width = getOption("width"), ...) {
  print(summary(x), digits = digits, width = width)
  invisible(x)
}

# Lines wrapped to `width` characters, continuation lines indented.
cat_wrapped <- function(lines, width) {
  if (length(lines) == 0L) return(invisible())  # cli::cat_line() would print a blank line
  cli::cat_line(unlist(lapply(lines, strwrap, width = width, exdent = 2)))
}

# A summary's table as print() shows it, within `width` characters: the
# estimate (or, in a table without it, the mean and median), the interval
# and the diagnostics, then a line saying which estimate is reported.
#' @export
`[.griddy_summary` <- function(x, ...) keep_level(NextMethod(), x)

# A subset of a summary keeps its level, so the bound columns and the
# estimate note still name it (`[.data.frame` keeps the class but drops the
# other attributes).
keep_level <- function(subset, x) {
  if (is.data.frame(subset)) attr(subset, "level") <- attr(x, "level")
  subset
}

print_summary_table <- function(x, digits, width, level) {
  tab <- format_summary_table(x, digits, level)
  old <- options(width = width)
  on.exit(options(old))
  print(tab, row.names = FALSE, right = TRUE)
  if (!is.null(x$estimate)) cat_wrapped(estimate_note(x$estimate_type, level), width)
  cat_wrapped(ess_tail_note(x), width)
}

# Why a tail ESS is NA beside a bulk ESS: posterior::ess_tail() measures how
# well the chains place the 5% and 95% quantiles, through the indicator of the
# draws at or below each; when the 95% quantile is the largest value drawn (a
# library value holding at least 5% of the draws) that indicator is constant
# and there is nothing to measure.
ess_tail_note <- function(x) {
  if (is.null(x$ess_tail) || is.null(x$ess_bulk)) return(character())
  at_edge <- x$parameter[is.na(x$ess_tail) & !is.na(x$ess_bulk)]
  if (!length(at_edge)) return(character())
  paste0("ess_tail NA: the 95% quantile of ", paste(at_edge, collapse = ", "),
         " is its largest value drawn (a library value holding at least 5% of the draws), ",
         "so the upper tail has no draws to measure; see ?summary.griddy_fit.")
}

# Each parameter's estimate and interval formatted on its own scale (a
# precision in the thousands beside a coefficient below 1 would force one
# format on both), effective sample sizes as integers, R-hat to 3 decimals,
# the MCSE to 2 significant digits.
format_summary_table <- function(x, digits, level) {
  tab <- as.data.frame(x)
  class(tab) <- "data.frame"
  if (!is.null(tab$estimate)) tab$mean <- tab$median <- NULL
  values <- intersect(c("estimate", "mean", "median", "lower", "upper"), names(tab))
  by_row <- vapply(seq_len(nrow(tab)), function(i) {
    format(unlist(tab[i, values]), digits = digits, scientific = 4, trim = TRUE)
  }, character(length(values)))
  tab[values] <- as.data.frame(matrix(by_row, nrow = nrow(tab), byrow = TRUE))
  marked <- tab$estimate_type %in% "median"
  if (any(marked)) tab$estimate <- paste0(tab$estimate, ifelse(marked, "*", " "))
  tab$estimate_type <- NULL
  for (ess in intersect(c("ess_bulk", "ess_tail"), names(tab))) {
    tab[[ess]] <- format(round(tab[[ess]]), trim = TRUE)
  }
  if (!is.null(tab$rhat)) tab$rhat <- formatC(tab$rhat, digits = 3, format = "f")
  if (!is.null(tab$mcse)) tab$mcse <- vapply(tab$mcse, format, "", digits = 2)
  if (!is.null(tab$resolution)) tab$resolution[is.na(tab$resolution)] <- ""
  # the bounds' probabilities, as confint() names them
  tail <- (1 - level) / 2
  names(tab)[names(tab) == "lower"] <- format_percent(tail)
  names(tab)[names(tab) == "upper"] <- format_percent(1 - tail)
  tab
}

# Which estimate the table reports, and why where it is the median.
estimate_note <- function(estimate_type, level) {
  paste0("estimate: posterior mean",
         if (any(estimate_type %in% "median")) {
           paste0("; * posterior median, where the mean lies outside the ", format(100 * level),
                  "% interval")
         }, ".")
}
