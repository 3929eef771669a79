# How a gap diagnosis reads: its advice and its print(), summary() and plot()
# methods (the verdict itself is decided in gap-verdict.R).

# The advice for confounded candidates: per candidate, where across x it and
# the parameter that absorbs it part (design_sentence(), from the diagnosis's
# `separation` table); for those whose comparison across x says nothing (one
# setting, alike at every one, or a diagnosis without the table), one sentence
# per absorbing parameter saying what it imitates (unless `explain` is FALSE:
# print()'s model lines say it), then once the generic design advice.
gap_advice <- function(which_tab, separation, x, explain = TRUE) {
  conf <- which_tab[which_tab$confounded, ]
  if (nrow(conf) == 0L) return(character(0))
  computed <- lapply(conf$effect, function(e) {
    if (!is.null(separation)) design_sentence(separation[separation$effect == e, ], x)
  })
  generic <- conf[vapply(computed, is.null, logical(1)), ]
  if (nrow(generic) == 0L) return(unlist(computed))
  by_param <- split(generic$effect, factor(generic$absorbed_by, unique(generic$absorbed_by)))
  absorbed <- vapply(names(by_param), function(p) {
    eff <- by_param[[p]]
    paste0(quoted_list(eff), if (length(eff) == 1L) " is" else " are", " confounded with ", p,
           ": at these settings a shift of ", p, " imitates ",
           if (length(eff) == 1L) "it." else "each.")
  }, character(1))
  c(unlist(computed), if (explain) unname(absorbed), design_advice(x))
}

# Where a measurement could separate a confounded candidate from theta. At
# the settings measured the effect acts as a shift of the absorbing
# parameter does, so new data must lie where the two differ: outside the
# range of the control settings measured (their ranges are given), or at a
# condition the simulator's parameter does not depend on.
design_advice <- function(x) {
  where <- if (is.null(x)) {
    "at a second value of a condition the effect depends on (this library has one setting)"
  } else if (nrow(x) == 1L) {
    paste0("at a second value of ", paste(names(x), collapse = " or "), " (this library has ",
           "one setting, ", gap_x_labels(list(x = x)), "), or at another condition the effect ",
           "depends on")
  } else {
    ranges <- vapply(x, function(v) paste0(format(min(v), digits = 3), "-",
                                            format(max(v), digits = 3)), "")
    paste0("outside the ", paste0(names(x), " range measured (", ranges, ")",
                                  collapse = ", "),
           ", or at a condition the effect depends on and the simulator does not")
  }
  paste0("To tell a confounded candidate from a shift of theta, measure ", where, ".")
}

# 'a', 'b' and 'c'
quoted_list <- function(v) {
  v <- paste0("'", v, "'")
  if (length(v) == 1L) return(v)
  paste0(paste(v[-length(v)], collapse = ", "), " and ", v[length(v)])
}

# A probability as a readable percentage: "42.7%", "< 0.1%", "> 99.9%"
# (never 1.1e-08 or a rounded 100.0%).
format_prob <- function(p) {
  ifelse(p < 0.001, "< 0.1%",
         ifelse(p > 0.999, "> 99.9%", paste0(formatC(100 * p, format = "f", digits = 1), "%")))
}

# "P = 42.7%", "P < 0.1%", "P(other) > 99.9%".
prob_phrase <- function(p, what = "P") {
  s <- format_prob(p)
  paste0(what, ifelse(grepl("^[<>]", s), " ", " = "), s)
}

# The probability of the model that fell short of the evidence bar (an
# older verdict without `short`: "other", 1 - P(none)).
short_phrase <- function(v) {
  if (is.null(v$short)) return(prob_phrase(1 - v$prob_none, "P(other)"))
  prob_phrase(v$short$prob, paste0("P(", v$short$effect, ")"))
}

# The verdict in a few words: a gap flagged by blocks but beaten in evidence
# by no model is named as such (its "other" probability, often tiny, says
# nothing about it).
verdict_label <- function(v) {
  switch(v$answer,
         none = if (identical(v$reason, "inconclusive")) {
           paste0("no detectable gap (inconclusive evidence, ", short_phrase(v), ")")
         } else if (identical(v$reason, "unweighable")) {
           "cannot tell (no evidence possible from a single measurement)"
         } else paste0("no gap (", prob_phrase(v$prob), ")"),
         other = if (identical(v$reason, "blocks")) {
           if (without_candidates(v)) "a local gap the smooth discrepancy misses" else
             "a local gap no candidate explains"
         } else if (without_candidates(v)) {
           paste0("a gap the simulator cannot absorb (", prob_phrase(v$prob, "P(other)"), ")")
         } else
           paste0("a gap no candidate explains (", prob_phrase(v$prob, "P(other)"), ")"),
         paste0("best explained by '", v$answer, "' (", prob_phrase(v$prob), ")"))
}

# The verdict as print() gives it: the label, then the one number that
# qualifies it (how far the answer shrinks the held-out gap; the mass of
# confounded candidates beside "none"; the flagged blocks behind "other").
verdict_line <- function(x) {
  v <- x$verdict
  sh <- x$shrinkage[x$shrinkage$effect == v$answer, ]
  conf_mass <- sum(x$which$prob[x$which$confounded])
  extra <- if (nrow(sh) == 1L && is.na(sh$shrink)) {
    paste0("; its held-out shrinkage is not identified by the held-out settings (",
           sh$unidentified, ")")
  } else if (nrow(sh) == 1L) {
    paste0("; held-out RMSE ", format(sh$before, digits = 3), " -> ",
           format(sh$after, digits = 3), " (", format_shrink(sh$shrink), " shrinkage)")
  } else if (v$answer == "none" && isTRUE(conf_mass > v$prob)) {
    paste0("; confounded candidates, which a shift of theta imitates, hold ",
           format_prob(conf_mass))
  } else if (identical(v$reason, "blocks")) {
    paste0(": ", v$n_flagged, " block", if (v$n_flagged != 1L) "s", " flagged, yet no model ",
           "beats the base model in evidence (", prob_phrase(v$prob_none, "P(none)"), ")")
  }
  paste0("Verdict: ", verdict_label(v), extra, ".")
}

# A shrinkage as a percentage with one decimal (no "-0.0%").
format_shrink <- function(s) {
  pct <- round(100 * s, 1)
  pct[pct == 0] <- 0
  paste0(formatC(pct, format = "f", digits = 1), "%")
}

# Where the gap is: the flagged blocks out of all, the `n_worst` worst named.
where_line <- function(x, n_worst = 1L, scores = FALSE) {
  wh <- x$where
  fdr <- paste0("FDR ", format(100 * x$settings$fdr), "%")
  fl <- wh[wh$flagged, ]
  out <- if (identical(x$settings$where, "unflagged")) {
    # replicates (or noise groups): the checks are shown, the evidence answers
    top <- utils::head(wh[order(wh$p_value), ], n_worst)
    paste0("Where: no block flagged: with replicated field data the block checks do not ",
           "decide, the evidence alone answers; least p-value ",
           paste0(format(top$p_value, digits = 2), " at ", block_place(x, top),
                  collapse = "; "))
  } else if (nrow(fl) == 0L) {
    paste0("Where: no block of ", nrow(wh), " flagged (", fdr, ")")
  } else {
    top <- utils::head(fl[order(fl$score, decreasing = TRUE), ], n_worst)
    spots <- paste0(block_place(x, top),
                    if (scores) paste0(" (score ", format(top$score, digits = 3), ")"))
    # without candidates a block is flagged for its discrepancy, not its misfit
    away <- identical(x$settings$where, "discrepancy")
    paste0("Where: ", nrow(fl), " of ", nrow(wh), " blocks ",
           if (!scores) "flagged" else if (away) {
             paste0(if (nrow(fl) == 1L) "has" else "have", " a discrepancy away from zero")
           } else if (nrow(fl) == 1L) "departs from the fitted noise" else
             "depart from the fitted noise", " (", fdr, "); worst at ",
           paste(spots, collapse = "; "))
  }
  n_empty <- sum(wh$n == 0L)
  if (n_empty > 0L) out <- paste0(out, "; ", n_empty, " block", if (n_empty != 1L) "s",
                                  " with no observed point not checked")
  paste0(out, ".")
}

# One line per model: its probability, the held-out shrinkage of a
# candidate, and what it is (base model, confounded, smooth discrepancy).
model_lines <- function(x) {
  w <- x$which
  shrink <- x$shrinkage$shrink[match(w$effect, x$shrinkage$effect)]
  note <- ifelse(w$confounded, paste0("confounded with ", w$absorbed_by), "")
  note[w$effect == "none"] <- "the base model"
  note[w$effect == "other"] <- "a smooth discrepancy"
  # a candidate whose held-out folds cannot learn its strength has none
  lost <- w$effect %in% x$shrinkage$effect[!shrinkage_identified(x$shrinkage)]
  cols <- list(c("model", w$effect), c("P", format_prob(w$prob)),
               c("shrinkage", ifelse(lost, "not identified",
                                     ifelse(is.na(shrink), "", format_shrink(shrink)))),
               c("", note))
  lines <- do.call(paste, c(lapply(cols, format), sep = "  "))
  paste0("  ", sub("\\s+$", "", lines))
}

# Per candidate of a shrinkage table, whether its held-out shrinkage is
# identified (a table without the column: every one).
shrinkage_identified <- function(sh) {
  if (is.null(sh$identified)) rep(TRUE, nrow(sh)) else sh$identified
}

# The sentence for a candidate whose held-out shrinkage is withheld
# (summarise_folds()): which settings' folds cannot learn its strength.
unidentified_sentence <- function(row) {
  paste0("The held-out shrinkage of '", row$effect, "' is not identified by the held-out ",
         "settings: leaving out ", row$unidentified, ", the other settings do not show its ",
         "effect (below the evidence bar), so its strength there, and the figure, would be ",
         "set by the strength grid, not by the data.")
}

wrap_lines <- function(s) {
  unlist(lapply(s, strwrap, width = getOption("width", 80L), exdent = 2L))
}

#' @export
print.gap_diagnosis <- function(x, ...) {
  n_cand <- nrow(x$which) - 2L
  what <- if (without_candidates(x$verdict)) "no candidates (a discrepancy against none)" else
    paste0(n_cand, " candidate", if (n_cand != 1L) "s")
  cli::cat_line("<gap_diagnosis> ", what, ", ", nrow(x$where), " blocks")
  cli::cat_line(wrap_lines(c(verdict_line(x), evidence_line(x), where_line(x))))
  cli::cat_line(model_lines(x))
  # the table's notes say what absorbs each confounded candidate
  cli::cat_line(wrap_lines(gap_advice(x$which, x$separation, x$x, explain = FALSE)))
  invisible(x)
}

#' Summarise a gap diagnosis
#'
#' The verdict of [diagnose_gap()] explained in full, with every model's
#' numbers: what `print()` shortens.
#'
#' `print()` of a `gap_diagnosis` is the short result: the verdict (the
#' answer, its probability and how far it shrinks the gap on held-out
#' settings), where the gap is (the worst flagged block), one line per model
#' and the design advice for confounded candidates, once. `summary()` adds
#' the explanation of the verdict, the three worst flagged blocks with their
#' scores, and the full tables.
#'
#' @param object A `gap_diagnosis` from [diagnose_gap()].
#' @param ... Unused.
#' @return A list of class `gap_diagnosis_summary`: `explanation` (the
#'   verdict in sentences), `where` (one sentence), `advice` (the sentences
#'   for confounded candidates), `models` (the diagnosis's `which` table with
#'   the columns of its `shrinkage` table for the candidates: `before` and
#'   `after` the held-out RMSE, `shrink` = 1 - after / before, `lpd_*` the
#'   leave-setting-out log predictive densities, `cover90_*` the coverage of
#'   90% predictive intervals; `NA` after where the held-out settings do not
#'   identify the candidate's strength, `identified` and `unidentified` saying
#'   so, see [diagnose_gap()]'s "How much"), `flagged` (the flagged blocks, worst first)
#'   and `settings`. Its `print()` shows them and returns it invisibly.
#' @examples
#' t <- seq(0, 1, length.out = 30)
#' x <- data.frame(load = c(1, 2, 3))
#' sim <- function(a, s) unlist(lapply(x$load, function(l) a * l * sin(3 * t) + s * l^2 * t^2))
#' base <- data.frame(a = seq(0.5, 1.5, length.out = 41))
#' lib <- sim_library(base, t(vapply(base$a, sim, numeric(90), s = 0)), x = x, t = t)
#' grid <- expand.grid(a = base$a, s = c(0, 0.1, 0.2, 0.3))
#' quad <- sim_library(grid, t(mapply(sim, grid$a, grid$s)), x = x, t = t)
#' set.seed(1)
#' field <- field_data(matrix(sim(1, 0.2) + rnorm(90, sd = 0.05), 3, byrow = TRUE), x = x, t = t)
#' fit <- calibrate(lib, field, n_iter = 500, burn_in = 100, seed = 1)
#' gap <- diagnose_gap(fit, list(quadratic = quad))
#' summary(gap)
#' summary(gap)$models
#' @export
summary.gap_diagnosis <- function(object, ...) {
  models <- object$which
  sh <- object$shrinkage
  models <- cbind(models, sh[match(models$effect, sh$effect), setdiff(names(sh), "effect")])
  rownames(models) <- NULL
  fl <- object$where[object$where$flagged, ]
  fl <- fl[order(fl$score, decreasing = TRUE), ]
  rownames(fl) <- NULL
  lost <- sh[!shrinkage_identified(sh) & sh$effect != object$verdict$answer, ]
  lost <- vapply(seq_len(nrow(lost)), function(i) unidentified_sentence(lost[i, ]), "")
  structure(list(explanation = c(verdict_explanation(object), lost, evidence_line(object)),
                 where = where_line(object, n_worst = 3L, scores = TRUE),
                 advice = gap_advice(object$which, object$separation, object$x),
                 models = models, flagged = fl,
                 settings = object$settings),
            class = "gap_diagnosis_summary")
}

# The verdict in sentences: what the answer means and the numbers behind it.
verdict_explanation <- function(x) {
  v <- x$verdict
  conf <- x$which[x$which$confounded, ]
  out <- switch(v$answer,
    none = if (identical(v$reason, "unweighable")) {
      paste0("griddy ", gap_unweighable_sentence, ".")
    } else if (identical(v$reason, "inconclusive")) {
      paste0("No detectable gap: the evidence for ",
             if (is.null(v$short) || v$short$effect == "other") "a discrepancy" else
               paste0("'", v$short$effect, "'"),
             " is inconclusive (", short_phrase(v), ", below the log odds of ",
             gap_detect_log_odds, " against 'none' that a gap needs), so the base model ",
             "stands.")
    } else if (nrow(conf) > 0L && sum(conf$prob) > v$prob) {
      paste0("No gap that theta cannot absorb: the base model and the confounded ",
             "candidate", if (nrow(conf) > 1L) "s", " ", quoted_list(conf$effect),
             " fit alike once theta is recalibrated (", prob_phrase(v$prob, "P(none)"),
             ", confounded ", format_prob(sum(conf$prob)), ").")
    } else {
      paste0("No detectable gap: the base model explains the data (",
             prob_phrase(v$prob, "P(none)"), ").")
    },
    other = if (without_candidates(v) && !identical(v$reason, "blocks")) {
      paste0("There is a gap the simulator cannot absorb: the base model plus a Gaussian-",
             "process discrepancy explains the data better than the base model (",
             prob_phrase(v$prob, "P(other)"), "). With the discrepancy, ", gap_theta_sentence,
             ".")
    } else if (identical(v$reason, "blocks")) {
      paste0("There is a gap that no candidate explains: ", v$n_flagged, " block",
             if (v$n_flagged != 1L) "s", " depart from the fitted noise, though no candidate ",
             "or smooth discrepancy beats the base model in evidence (",
             prob_phrase(v$prob_none, "P(none)"), "); the gap is local or rough.")
    } else {
      paste0("There is a gap that no candidate explains: a generic smooth discrepancy does ",
             "best (", prob_phrase(v$prob, "P(other)"), ").")
    },
    paste0("The gap is best explained by '", v$answer, "' (", prob_phrase(v$prob), ")."))
  sh <- x$shrinkage[x$shrinkage$effect == v$answer, ]
  if (nrow(sh) == 1L && is.na(sh$shrink)) {
    out <- paste0(out, " ", unidentified_sentence(sh))
  } else if (nrow(sh) == 1L) {
    out <- paste0(out, " Adding it cuts the RMSE of held-out settings from ",
                  format(sh$before, digits = 3), " to ", format(sh$after, digits = 3), " (",
                  format_shrink(sh$shrink), " shrinkage; 90% coverage ",
                  format(sh$cover90_before, digits = 2), " -> ",
                  format(sh$cover90_after, digits = 2), ").")
  }
  out
}

#' @export
print.gap_diagnosis_summary <- function(x, digits = 3, ...) {
  s <- x$settings
  n_cand <- nrow(x$models) - 2L
  head <- if (is.null(s$confounding_threshold)) {
    paste0("Gap diagnosis without candidates: the base model ('none') against it plus a ",
           "Gaussian-process discrepancy ('other'); blocks flagged where the discrepancy's ",
           "posterior is away from zero, at FDR ", format(100 * s$fdr), "%.")
  } else {
    paste0("Gap diagnosis: ", n_cand, " candidate", if (n_cand != 1L) "s",
           " against the base model ('none') ",
           "and a smooth discrepancy ('other'); blocks flagged at FDR ", format(100 * s$fdr),
           "%; confounded below a separable fraction of ", format(s$confounding_threshold), ".")
  }
  cli::cat_line(wrap_lines(head))
  cli::cat_line(wrap_lines(c(x$explanation, x$where, x$advice)))
  m <- x$models
  # each number to `digits` significant digits on its own (a column of
  # print.data.frame gives them all the digits its smallest entry needs)
  m[] <- lapply(m, function(v) {
    if (is.numeric(v)) vapply(v, format, "", digits = digits) else v
  })
  m$prob <- format_prob(x$models$prob)
  cli::cat_line("Models:")
  cols <- c("effect", "prob", "log_evidence")
  # the confounding columns say something only of candidates
  if (!is.null(s$confounding_threshold)) {
    cols <- c(cols, "confounded", "separable", "detectable", "absorbed_by")
  }
  print(m[cols], row.names = FALSE)
  cand <- m[!x$models$effect %in% c("none", "other"), ]
  if (nrow(cand) > 0L) {
    lost <- !shrinkage_identified(x$models[!x$models$effect %in% c("none", "other"), ])
    cli::cat_line("Held-out settings (each x setting left out in turn",
                  if (any(lost)) "; NA: not identified", "):")
    print(cand[c("effect", "before", "after", "shrink", "lpd_before", "lpd_after",
                 "cover90_before", "cover90_after")], row.names = FALSE)
  }
  invisible(x)
}

#' Plot a gap diagnosis
#'
#' A map of the gap: the base model's posterior-mean residual in units of
#' the fitted noise standard deviation over t (horizontal) and x setting
#' (vertical), with the blocks flagged by [diagnose_gap()] outlined. With a
#' single output per setting, a bar per setting instead.
#'
#' @param x A `gap_diagnosis` from [diagnose_gap()].
#' @param ... Unused.
#' @return A ggplot object.
#' @examples
#' t <- seq(0, 1, length.out = 30)
#' x <- data.frame(load = c(1, 2, 3))
#' sim <- function(a, s) unlist(lapply(x$load, function(l) a * l * sin(3 * t) + s * l^2 * t^2))
#' base <- data.frame(a = seq(0.5, 1.5, length.out = 41))
#' lib <- sim_library(base, t(vapply(base$a, sim, numeric(90), s = 0)), x = x, t = t)
#' grid <- expand.grid(a = base$a, s = c(0, 0.1, 0.2, 0.3))
#' quad <- sim_library(grid, t(mapply(sim, grid$a, grid$s)), x = x, t = t)
#' set.seed(1)
#' field <- field_data(matrix(sim(1, 0.2) + rnorm(90, sd = 0.05), 3, byrow = TRUE), x = x, t = t)
#' fit <- calibrate(lib, field, n_iter = 500, burn_in = 100, seed = 1)
#' plot(diagnose_gap(fit, list(quadratic = quad)))
#' @export
plot.gap_diagnosis <- function(x, ...) {
  map <- x$map
  lab <- gap_x_labels(x)
  map$setting <- factor(lab[map$x], levels = lab)
  wh <- x$where
  wh$setting <- factor(lab[wh$x], levels = lab)
  lim <- max(3, max(abs(map$z), na.rm = TRUE))
  # without candidates the map is the discrepancy's posterior mean, in its
  # posterior sds
  discrepancy <- identical(x$settings$where, "discrepancy")
  z_name <- if (discrepancy) "Discrepancy /\nposterior sd" else "Residual /\nnoise sd"
  # two lines, the verdict on the second: on one it ran past a vignette-width figure
  title <- paste0("Gap map: ", sum(wh$flagged, na.rm = TRUE), " of ", nrow(wh),
                  " blocks flagged\n", paste(strwrap(verdict_label(x$verdict), 60), collapse = "\n"))
  if (length(x$t) == 1L) {
    map$flagged <- wh$flagged[match(map$x, wh$x)]
    return(ggplot2::ggplot(map, ggplot2::aes(.data$setting, .data$z, fill = .data$flagged)) +
             ggplot2::geom_col() +
             ggplot2::geom_hline(yintercept = c(-2, 2), linetype = 2, colour = "grey40") +
             ggplot2::scale_fill_manual(values = c(`FALSE` = "grey60", `TRUE` = "firebrick")) +
             ggplot2::labs(x = "x setting", y = sub("\n", " ", z_name, fixed = TRUE),
                           fill = "Flagged",
                           title = title) +
             ggplot2::scale_x_discrete(guide = ggplot2::guide_axis(check.overlap = TRUE)) +
             ggplot2::theme_bw() +
             ggplot2::theme(axis.text.x = ggplot2::element_text(angle = 90, hjust = 1)))
  }
  dt <- if (length(x$t) > 1L) stats::median(diff(x$t)) / 2 else 0.5
  fl <- wh[wh$flagged, ]
  p <- ggplot2::ggplot(map, ggplot2::aes(.data$t, .data$setting, fill = .data$z)) +
    ggplot2::geom_tile() +
    ggplot2::scale_fill_gradient2(low = "#2166ac", mid = "white", high = "#b2182b",
                                  limits = c(-lim, lim), name = z_name)
  if (nrow(fl) > 0L) {
    p <- p + ggplot2::geom_rect(data = fl, inherit.aes = FALSE,
                                ggplot2::aes(xmin = .data$from - dt, xmax = .data$to + dt,
                                             ymin = as.numeric(.data$setting) - 0.5,
                                             ymax = as.numeric(.data$setting) + 0.5),
                                fill = NA, colour = "black", linewidth = 0.8)
  }
  # many settings: the labels that overlap are left out
  p + ggplot2::scale_y_discrete(guide = ggplot2::guide_axis(check.overlap = TRUE)) +
    ggplot2::labs(x = "t", y = "x setting", title = title,
                  subtitle = if (discrepancy) {
                    "Outlined: blocks where the discrepancy is away from zero"
                  } else "Outlined: blocks the fitted noise does not explain") +
    # the titles start at the figure's edge, not the panel's: long setting
    # labels pushed them past the right edge
    ggplot2::theme_bw() + ggplot2::theme(plot.title.position = "plot")
}

# A diagnosis made without candidates (gap-discrepancy.R): its
# verdict weighs the base model against a Gaussian-process discrepancy.
without_candidates <- function(v) identical(v$mode, "discrepancy")

# print()'s line on the discrepancy's evidence, without candidates.
evidence_line <- function(x) {
  ev <- x$evidence
  if (is.null(ev)) return(character(0))
  paste0("Evidence: log Bayes factor for a discrepancy ", format(ev$log_bayes_factor, digits = 3),
         " (", evidence_words(ev$log_bayes_factor), "), at matched resolution (",
         x$settings$runs, " runs): exact, on a library refined until the posterior is ",
         "resolved, so it exceeds calibrate()'s screen (a lower bound from the fit's own ",
         "runs) and may differ from a discrepancy fit on the unrefined library.")
}

# Where blocks `blocks` (rows of a diagnosis's `where`) are: "load=6, t
# 0.2-0.6", "t = 0.2" for a block of one t value; the setting alone when
# the library has one output per setting ("t 1-1" said nothing), t alone
# when it has one setting; "the single output" when both.
block_place <- function(x, blocks) {
  setting <- if (!is.null(x$x)) gap_x_labels(x)[blocks$x]
  t_part <- if (length(x$t) > 1L) {
    ends <- matrix(format(c(blocks$from, blocks$to), digits = 3), ncol = 2L)
    ifelse(blocks$from == blocks$to, paste0("t = ", ends[, 1]),
           paste0("t ", ends[, 1], "-", ends[, 2]))
  }
  if (is.null(setting) && is.null(t_part)) return(rep("the single output", nrow(blocks)))
  if (is.null(setting)) return(t_part)
  if (is.null(t_part)) setting else paste0(setting, ", ", t_part)
}

# Each x setting by its values, "load=6, speed=10", however many there are
# (a setting's row number told a reader nothing); "1" for the single one.
gap_x_labels <- function(x) {
  if (is.null(x$x)) return("1")
  # each value formatted alone: together they were padded to one width ("load= 2")
  apply(x$x, 1, function(r) paste0(names(x$x), "=", vapply(r, format, "", digits = 3),
                                   collapse = ", "))
}
