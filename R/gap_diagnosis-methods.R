# The verdict of a gap diagnosis, and its print() and plot() methods.

# One sentence per confounded candidate: what absorbs it, and where a
# measurement could separate them. At the settings measured the effect acts
# as a shift of the absorbing parameter does, so new data must lie where the
# two differ: outside the range of the control settings measured (their
# ranges are given), or at a condition the simulator's parameter does not
# depend on.
gap_advice <- function(which_tab, x) {
  conf <- which_tab[which_tab$confounded, ]
  where <- if (is.null(x)) {
    "at a second value of a condition the effect depends on (this library has one setting)"
  } else {
    ranges <- vapply(x, function(v) paste0(format(min(v), digits = 3), "-",
                                            format(max(v), digits = 3)), "")
    paste0("outside the ", paste0(names(x), " range measured (", ranges, ")",
                                  collapse = ", "),
           ", or at a condition the effect depends on and the simulator does not")
  }
  vapply(seq_len(nrow(conf)), function(i) {
    paste0("'", conf$effect[i], "' is confounded with ", conf$absorbed_by[i], ": at these ",
           "settings a shift of ", conf$absorbed_by[i], " imitates it (separable fraction ",
           format(round(conf$separable[i], 3)), "). To tell them apart, measure ", where, ".")
  }, character(1))
}

gap_verdict <- function(which_tab, screen, base, where) {
  ok <- !which_tab$confounded
  answer <- which_tab$effect[ok][1]
  prob <- which_tab$prob[ok][1]
  # the base model fails its own check: a gap is there even if no smooth
  # discrepancy beats it in evidence (e.g. a gap too local or too rough)
  n_flagged <- sum(where$blocks$flagged)
  reason <- if (answer == "none" && n_flagged > 0L) "blocks" else "evidence"
  if (reason == "blocks") {
    answer <- "other"
    prob <- which_tab$prob[which_tab$effect == "other"]
  }
  conf <- which_tab$effect[which_tab$confounded]
  advice <- gap_advice(which_tab, lib_x(base))
  list(answer = answer, prob = prob, reason = reason, confounded = conf,
       advice = unname(advice), n_flagged = n_flagged,
       prob_none = which_tab$prob[which_tab$effect == "none"])
}

#' @export
print.gap_diagnosis <- function(x, ...) {
  v <- x$verdict
  wh <- x$where
  pct <- function(p) paste0(format(round(100 * p, 1), nsmall = 1), "%")
  cli::cat_line("<gap_diagnosis> ", nrow(x$which) - 2L, " candidate effect(s), ",
                nrow(wh), " block(s)")
  headline <- switch(v$answer,
    none = {
      conf <- x$which[x$which$confounded, ]
      if (nrow(conf) > 0L && sum(conf$prob) > v$prob) {
        paste0("No gap that theta cannot absorb: the base model and the confounded ",
               "candidate(s) ", paste0("'", conf$effect, "'", collapse = ", "),
               " fit alike once theta is recalibrated (P(none) = ", pct(v$prob),
               ", confounded ", pct(sum(conf$prob)), ").")
      } else {
        paste0("No detectable gap: the base model explains the data (P(none) = ",
               pct(v$prob), ").")
      }
    },
    other = if (identical(v$reason, "blocks")) {
      paste0("There is a gap that no candidate explains: ", v$n_flagged, " block(s) depart ",
             "from the fitted noise, though no candidate or smooth discrepancy beats the ",
             "base model in evidence (P(none) = ", pct(v$prob_none), "); the gap is local ",
             "or rough.")
    } else {
      paste0("There is a gap that no candidate explains: a generic smooth ",
             "discrepancy does best (P(other) = ", pct(v$prob), ").")
    },
    paste0("The gap is best explained by '", v$answer, "' (P = ", pct(v$prob), ")."))
  sh <- x$shrinkage[x$shrinkage$effect == v$answer, ]
  if (nrow(sh) == 1L) {
    headline <- paste0(headline, " Adding it cuts the RMSE of held-out settings from ",
                       format(sh$before, digits = 3), " to ", format(sh$after, digits = 3),
                       " (", pct(sh$shrink), " shrinkage; 90% coverage ",
                       format(sh$cover90_before, digits = 2), " -> ",
                       format(sh$cover90_after, digits = 2), ").")
  }
  cli::cat_line(strwrap(headline, width = 90))
  fl <- wh[wh$flagged, ]
  if (nrow(fl) > 0L) {
    fl <- fl[order(fl$score, decreasing = TRUE), ]
    top <- utils::head(fl, 3L)
    cli::cat_line(strwrap(paste0(
      "Where: ", nrow(fl), " of ", nrow(wh), " block(s) depart from the fitted noise (FDR ",
      pct(x$settings$fdr), "), worst at ",
      paste0("x ", top$x, ", t ", format(top$from, digits = 3), "-", format(top$to, digits = 3),
             " (score ", format(top$score, digits = 3), ")", collapse = "; "), "."),
      width = 90))
  } else {
    cli::cat_line("Where: no block departs from the fitted noise (FDR ", pct(x$settings$fdr), ").")
  }
  n_empty <- sum(wh$n == 0L)
  if (n_empty > 0L) {
    cli::cat_line(n_empty, " block(s) with no observed point were not checked (n = 0 in ",
                  "$where).")
  }
  for (a in gap_advice(x$which, x$x)) cli::cat_line(strwrap(a, width = 90))
  p <- ifelse(x$which$prob < 0.001, "<0.001", sprintf("%.3f", x$which$prob))
  cli::cat_line("Models (posterior probability): ",
                paste0(x$which$effect, ifelse(x$which$confounded, " [confounded]", ""), " ",
                       p, collapse = ", "))
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
  title <- paste0("Gap map: ", sum(wh$flagged, na.rm = TRUE), " of ", nrow(wh),
                  " block(s) flagged; ", verdict_label(x$verdict))
  if (length(x$t) == 1L) {
    map$flagged <- wh$flagged[match(map$x, wh$x)]
    return(ggplot2::ggplot(map, ggplot2::aes(.data$setting, .data$z, fill = .data$flagged)) +
             ggplot2::geom_col() +
             ggplot2::geom_hline(yintercept = c(-2, 2), linetype = 2, colour = "grey40") +
             ggplot2::scale_fill_manual(values = c(`FALSE` = "grey60", `TRUE` = "firebrick")) +
             ggplot2::labs(x = "x setting", y = "Residual / noise sd", fill = "Flagged",
                           title = title) +
             ggplot2::theme_bw() +
             ggplot2::theme(axis.text.x = ggplot2::element_text(angle = 90, hjust = 1)))
  }
  dt <- if (length(x$t) > 1L) stats::median(diff(x$t)) / 2 else 0.5
  fl <- wh[wh$flagged, ]
  p <- ggplot2::ggplot(map, ggplot2::aes(.data$t, .data$setting, fill = .data$z)) +
    ggplot2::geom_tile() +
    ggplot2::scale_fill_gradient2(low = "#2166ac", mid = "white", high = "#b2182b",
                                  limits = c(-lim, lim), name = "Residual /\nnoise sd")
  if (nrow(fl) > 0L) {
    p <- p + ggplot2::geom_rect(data = fl, inherit.aes = FALSE,
                                ggplot2::aes(xmin = .data$from - dt, xmax = .data$to + dt,
                                             ymin = as.numeric(.data$setting) - 0.5,
                                             ymax = as.numeric(.data$setting) + 0.5),
                                fill = NA, colour = "black", linewidth = 0.8)
  }
  p + ggplot2::labs(x = "t", y = "x setting", title = title,
                    subtitle = "Outlined: blocks the fitted noise does not explain") +
    ggplot2::theme_bw()
}

# The verdict in a few words: a gap flagged by blocks but beaten in evidence
# by no model is named as such (its "other" probability, often tiny, says
# nothing about it).
verdict_label <- function(v) {
  pct <- function(p) if (p < 0.001) "< 0.1%" else paste0(format(100 * p, digits = 3), "%")
  switch(v$answer,
         none = paste0("no gap (P = ", pct(v$prob), ")"),
         other = if (identical(v$reason, "blocks")) "a local gap no candidate explains" else
           paste0("a gap no candidate explains (P(other) = ", pct(v$prob), ")"),
         paste0("best explained by '", v$answer, "' (P = ", pct(v$prob), ")"))
}

gap_x_labels <- function(x) {
  if (is.null(x$x)) return("1")
  if (nrow(x$x) > 12L) return(as.character(seq_len(nrow(x$x))))
  apply(x$x, 1, function(r) paste0(names(x$x), "=", format(r, digits = 3), collapse = ", "))
}
