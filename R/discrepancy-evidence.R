# Is there a gap? The Bayes factor for a discrepancy, read off the exact grid
# posterior of a fit with a gp_discrepancy() (the ratio 0 is the model
# without one), and the warning calibrate() gives when it is large.

#' Evidence for a model discrepancy
#'
#' The Bayes factor for "the simulator misses the data" against "it does
#' not", from a fit or exact posterior with a [gp_discrepancy()]: the model
#' with the discrepancy ratio \eqn{\lambda > 0} against \eqn{\lambda = 0}, both
#' integrated over the library runs and the correlation grid, exactly. It is
#' the posterior odds of \eqn{\lambda > 0} divided by the prior odds.
#'
#' The factor depends on the grid of `ratio` and its prior (a wider grid
#' spreads the discrepancy's prior thinner); the posterior over the ratio
#' and the length scales (`ratio`, `length_x`, `length_t`) shows what the
#' data say about the discrepancy's size and smoothness.
#'
#' A large factor says the data show a structure that the library's runs and
#' the noise model cannot give. When the library's runs are too sparse for
#' the data (a resolution warning), part of that structure can be the gap
#' between the runs rather than a gap of the simulator: [refine()] first,
#' or use [diagnose_gap()], which compares at matched resolution.
#'
#' @param fit A [calibrate()] fit or a [posterior_exact()] result made with
#'   `discrepancy = gp_discrepancy()` whose `ratio` holds 0.
#' @return A list of class `griddy_discrepancy_evidence`: `log_bayes_factor`
#'   (natural log, discrepancy against none), `prob_none` (the posterior
#'   probability of no discrepancy), `prior_none`, and `ratio`, `length_x`,
#'   `length_t`: data.frames with the posterior probability (`prob`) of each
#'   value (among \eqn{\lambda > 0} for the lengths).
#' @examples
#' ex <- griddy_example()
#' exact <- posterior_exact(ex$library, ex$field, discrepancy = gp_discrepancy())
#' discrepancy_evidence(exact)
#' @export
discrepancy_evidence <- function(fit) {
  grid <- evidence_grid(fit)
  none <- grid$delta_ratio == 0
  prior_none <- attr(grid, "prior_none")
  prob_none <- sum(grid$prob[none])
  # in logs, which do not underflow: log (prior x evidence) of each model
  log_mass <- attr(grid, "log_grid_mass")
  log_bf <- log_sum_exp(log_mass[!none]) - log_sum_exp(log_mass[none]) -
    (log1p(-prior_none) - log(prior_none))
  positive <- grid[!none, , drop = FALSE]
  margin <- function(col) {
    if (!col %in% names(positive)) return(NULL)
    m <- stats::aggregate(list(prob = positive$prob), positive[col], sum)
    m$prob <- m$prob / max(sum(m$prob), .Machine$double.xmin)
    m
  }
  ratio <- stats::aggregate(list(prob = grid$prob), grid["delta_ratio"], sum)
  names(ratio)[1] <- "ratio"
  structure(list(log_bayes_factor = log_bf,
                 prob_none = prob_none, prior_none = prior_none, ratio = ratio,
                 length_x = margin("delta_length_x"), length_t = margin("delta_length_t")),
            class = "griddy_discrepancy_evidence")
}

# The grid with its posterior probabilities, of a fit (its exact margins) or
# an exact posterior, with the prior probability of no discrepancy as an
# attribute; an error for anything without a discrepancy whose ratio holds 0.
evidence_grid <- function(fit) {
  exact <- if (inherits(fit, "griddy_fit")) fit$exact else fit
  if (!inherits(exact, "griddy_exact")) {
    griddy_abort("`fit` must be a griddy_fit or a griddy_exact; received ", class(fit)[1], ".",
                 class = "input")
  }
  grid <- exact$grid
  disc <- attr(exact, "discrepancy")
  if (is.null(grid$delta_ratio) || !any(grid$delta_ratio == 0) || !any(grid$delta_ratio > 0)) {
    griddy_abort("`fit` has no discrepancy to weigh: make it with `discrepancy = ",
                 "gp_discrepancy()` and a `ratio` grid that holds 0 and positive values.",
                 class = "input")
  }
  attr(grid, "prior_none") <- exp(disc$log_prior[disc$ratio == 0])
  attr(grid, "log_grid_mass") <- attr(exact, "log_grid_mass")
  grid
}

#' @export
print.griddy_discrepancy_evidence <- function(x, ...) {
  cli::cat_line("<griddy_discrepancy_evidence>")
  cli::cat_line("  log Bayes factor, discrepancy against none: ",
                format(x$log_bayes_factor, digits = 3), " (", evidence_words(x$log_bayes_factor),
                ")")
  cli::cat_line("  posterior probability of no discrepancy: ", format(x$prob_none, digits = 3),
                " (prior ", format(x$prior_none, digits = 3), ")")
  top <- x$ratio[which.max(x$ratio$prob), ]
  cli::cat_line("  most probable ratio (discrepancy / noise variance): ",
                format(top$ratio, digits = 3), " (", format(top$prob, digits = 3), ")")
  invisible(x)
}

# Kass and Raftery's (1995) scale, on the natural log of the factor.
evidence_words <- function(log_bf) {
  if (!is.finite(log_bf)) return(if (log_bf > 0) "decisive for a discrepancy" else "none")
  breaks <- c(-Inf, -log(20), -1, 1, log(20), log(150), Inf)
  words <- c("strong against a discrepancy", "against a discrepancy", "inconclusive",
             "positive for a discrepancy", "strong for a discrepancy",
             "very strong for a discrepancy")
  words[findInterval(log_bf, breaks)]
}

# calibrate()'s warning when its discrepancy shows a gap (nothing when the
# fit has no discrepancy to weigh), with where the gap lies: the settings
# and outputs where the posterior of delta is clear of 0
# (discrepancy_where_text(), from exact mixture moments: no random numbers,
# so the caller's stream is untouched).
warn_gap <- function(fit) {
  if (is.null(fit$setup$discrepancy)) return(invisible(NULL))
  ev <- tryCatch(discrepancy_evidence(fit), griddy_error_input = function(e) NULL)
  # the one rule of gap-verdict.R (under the fit's prior on no discrepancy,
  # the log Bayes factor stands for the log odds), with the base model's
  # block checks as calibrate() without a discrepancy runs them
  # (gap_screen())
  blocks <- fit$gap_screen$blocks
  n_flagged <- if (is.null(blocks)) 0L else sum(blocks$flagged)
  if (is.null(ev) || screen_unweighable(fit) || !gap_shown(ev$log_bayes_factor, n_flagged)) {
    return(invisible(NULL))
  }
  griddy_warn(gap_message(ev$log_bayes_factor, theta_estimand(fit$setup$discrepancy),
                          discrepancy_where_text(fit), resolution_caveat(fit),
                          local_misfit_text(blocks, fit$library)), class = "gap")
}

# The base model's flagged blocks `blocks` as a clause, or NULL when none is.
local_misfit_text <- function(blocks, library = NULL) {
  flagged <- if (!is.null(blocks)) blocks[blocks$flagged, , drop = FALSE]
  if (NROW(flagged) == 0L) return(NULL)
  paste0("the model's leave-block-out checks without the discrepancy flag ", nrow(flagged),
         " block", if (nrow(flagged) > 1L) "s", " (", flagged_blocks_text(flagged, library),
         ") as a local misfit")
}

# What a gap found on a library too coarse for the data may be instead.
resolution_caveat <- function(fit) {
  tab <- resolution_limited(fit)
  if (!any(tab$limited & !tab$constant)) return(NULL)
  paste0("(The library's resolution limits this fit: part of the gap may be the misfit ",
         "between its runs; refine() it first.)")
}

# `estimand`: what theta then is (theta_estimand() of the fit's discrepancy);
# `local`: local_misfit_text() of the base model's block checks.
gap_message <- function(log_bf, estimand, where = NULL, caveat = NULL, local = NULL) {
  paste0("The field data show a gap between the simulator and reality: the log Bayes ",
         "factor for a discrepancy is ", format(log_bf, digits = 3), " (",
         evidence_words(log_bf), ")",
         if (!is.null(local)) {
           paste0(if (gap_shown(log_bf)) ", and " else ", but ", local,
                  if (!gap_shown(log_bf)) ", a gap too local for the smooth discrepancy")
         }, ". ",
         if (!is.null(where)) paste0(where, " "),
         estimand, " See where the gap lies with ",
         "plot(fit, \"discrepancy\"), and which effect may cause it with diagnose_gap().",
         if (!is.null(caveat)) paste0(" ", caveat))
}
