#' Plot a griddy fit
#'
#' * `"trace"`: the draws of every parameter against the iteration, one line
#'   per chain, thinned for display to at most `max_points` draws per chain
#'   (the subtitle says which are shown; the summaries use them all).
#' * `"posterior"`: the posterior of each \eqn{\theta} column as bars over the
#'   library's distinct values (the thesis's figures), with the truth marked
#'   when given; for a library from [refine()] or a scattered design (a
#'   Latin hypercube, an [emulated_library()]: values that do not repeat), a
#'   density: the runs weighted by their exact posterior probability and
#'   smoothed by a Gaussian kernel whose bandwidth is Silverman's rule of
#'   thumb for the *effective* number of runs \eqn{1 / \sum_i p_i^2} (the
#'   subtitle gives it), not for the number of draws. A resolved fit of a
#'   scattered design can rest on some 20 effective runs out of 10,000; a
#'   histogram of its draws shows those runs as spikes, which are the
#'   library's sampling, not the posterior's shape. The density is cut at the
#'   library's range (the posterior has no mass outside it) and drawn where
#'   the runs with mass are.
#' * `"ppc"`: posterior predictive check: the field data against the
#'   simulator outputs at the drawn runs (mean and band) and the predictive
#'   band with the fitted noise, against t, one panel per x setting
#'   (titled by its values, "load = 6"); with one output per setting, against
#'   the setting: its value when the library has one x column, its label
#'   when several. With `newdata` holding settings the library does not hold
#'   (and `simulator`, or an [emulated_library()] whose design reaches them;
#'   see [predict.griddy_fit()]), the prediction there is drawn beside the
#'   library's settings, in orange: with one x column and one output per
#'   setting on one continuous x axis (bands joined across the settings,
#'   the library's range of x between dashed lines, beyond which the
#'   prediction extrapolates); otherwise one panel per setting, the new
#'   ones titled "(new)" (in x's order when there is one x column).
#' * `"pairs"`: the joint posterior of every pair of \eqn{\theta} columns,
#'   the draws binned in two dimensions, so that ridges (parameters that
#'   trade off) show; the truth is marked when given. With one pair the axes
#'   are titled by the parameters' names; with several each panel is titled
#'   "a (x), b (y)".
#' * `"discrepancy"`: for a fit with a [gp_discrepancy()], where the
#'   simulator misses the data: the posterior of the discrepancy
#'   \eqn{\delta} ([discrepancy_posterior()]: mean and pointwise band)
#'   against t, one panel per x setting (placed as in `"ppc"`), with the
#'   field data's residuals from the simulator's posterior mean outputs as
#'   points. Where the band leaves 0 (the dashed line), the data show a gap
#'   there.
#'
#' @param x A `griddy_fit` from [calibrate()].
#' @param type `"trace"`, `"posterior"`, `"ppc"`, `"pairs"` or
#'   `"discrepancy"`.
#' @param truth Optional named numeric vector of true \eqn{\theta} values,
#'   marked in red on the `"posterior"` and `"pairs"` plots.
#' @param max_points For `"trace"`, the most draws per chain drawn.
#' @param ... Passed to [predict.griddy_fit()] for `"ppc"` (e.g. `level`,
#'   `ndraws`, `seed`, `discrepancy`, and `newdata`, `simulator`, `run_mass`
#'   for new settings), and to [discrepancy_posterior()] for
#'   `"discrepancy"` (`level`, `ndraws`, `seed`).
#' @return A ggplot object.
#' @examples
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 1000, burn_in = 200, seed = 1)
#' plot(fit, "posterior", truth = ex$truth)
#' plot(fit, "ppc", ndraws = 200, seed = 1)
#' plot(fit, "pairs", truth = ex$truth)
#' fit_d <- calibrate(ex$library, ex$field, n_iter = 1000, burn_in = 200, seed = 1,
#'                    discrepancy = gp_discrepancy(length_x = 1, length_t = c(0.3, 1)))
#' plot(fit_d, "discrepancy", ndraws = 200, seed = 1)

#' # predicting beyond the library: the simple machine (simulator theta x,
#' # reality theta x / (1 + x / 20)), calibrated on x in [0.2, 4]
#' x <- data.frame(x = seq(0.2, 4, length.out = 11))
#' theta <- data.frame(theta = seq(0.3, 1, by = 0.0025))
#' lib <- sim_library(theta, outer(theta$theta, x$x), x = x)
#' set.seed(1)
#' field <- field_data(matrix(0.65 * x$x / (1 + x$x / 20) + rnorm(11, sd = 0.01)), x = x)
#' fit_m <- calibrate(lib, field, n_iter = 2000, burn_in = 200, seed = 1,
#'                    discrepancy = gp_discrepancy(zero_at = data.frame(x = 0),
#'                                                 flat_at = data.frame(x = 0)))
#' plot(fit_m, "ppc", newdata = data.frame(x = seq(4.5, 6, by = 0.5)),
#'      simulator = function(theta, x) outer(theta$theta, x$x), seed = 1)
#' @importFrom ggplot2 .data
#' @export
plot.griddy_fit <- function(x, type = c("trace", "posterior", "ppc", "pairs", "discrepancy"),
                            truth = NULL, max_points = 1000, ...) {
  type <- assert_choice(type, "type", c("trace", "posterior", "ppc", "pairs", "discrepancy"),
                        vector_default = TRUE)
  switch(type,
         trace = plot_trace(x, assert_count(max_points, "max_points", min = 2L)),
         posterior = plot_posterior(x, truth),
         ppc = plot_ppc(x, ...),
         pairs = plot_pairs(x, truth),
         discrepancy = plot_discrepancy(x, ...))
}

# Thousands of draws per chain draw as a solid block (and take seconds to
# save): every k-th draw is shown, at most `max_points` per chain.
plot_trace <- function(fit, max_points) {
  draws <- parameter_draws(fit)
  per_chain <- max(tabulate(fit$draws$chain))
  step <- max(1L, ceiling(per_chain / max_points))
  shown <- stats::ave(seq_along(fit$draws$chain), fit$draws$chain, FUN = seq_along) %% step == 1L |
    step == 1L
  draws <- draws[shown, , drop = FALSE]
  long <- data.frame(iteration = fit$draws$iteration[shown],
                     chain = factor(fit$draws$chain[shown]),
                     parameter = factor(rep(names(draws), each = nrow(draws)),
                                        levels = names(draws)),
                     value = unlist(draws, use.names = FALSE))
  ggplot2::ggplot(long, ggplot2::aes(.data$iteration, .data$value, colour = .data$chain)) +
    ggplot2::geom_line(linewidth = 0.3) +
    ggplot2::facet_wrap(ggplot2::vars(.data$parameter), ncol = 1, scales = "free_y") +
    ggplot2::labs(x = "Iteration", y = "Draw", colour = "Chain",
                  title = "Trace plots",
                  subtitle = if (step > 1L) paste0("One kept draw in ", step, " shown (",
                                                   sum(shown), " of ", length(shown), ")")) +
    ggplot2::theme_bw()
}

pair_label <- function(pair) paste0(pair[1], " (x), ", pair[2], " (y)")

# Every pair of theta columns: the draws binned on a 40 x 40 grid over the
# range they visit, one panel per pair.
plot_pairs <- function(fit, truth) {
  theta <- lib_theta(fit$library)
  names_ <- names(theta)[vapply(theta, function(v) length(unique(v)) > 1L, logical(1))]
  if (length(names_) < 2L) {
    griddy_abort("A pairs plot needs at least two theta columns that vary; this library has ",
                 length(names_), ".")
  }
  pairs <- utils::combn(names_, 2L, simplify = FALSE)
  drawn <- rows_at(theta, fit$draws$run)
  panel <- vapply(pairs, pair_label, "")
  long <- do.call(rbind, Map(function(pr, label) {
    data.frame(pair = factor(label, levels = panel), x = drawn[[pr[1]]], y = drawn[[pr[2]]])
  }, pairs, panel))
  p <- ggplot2::ggplot(long, ggplot2::aes(.data$x, .data$y)) +
    ggplot2::geom_bin2d(bins = 40) +
    ggplot2::scale_fill_gradient(low = "grey90", high = "steelblue4", name = "Draws") +
    ggplot2::facet_wrap(ggplot2::vars(.data$pair), scales = "free") +
    ggplot2::labs(x = if (length(pairs) == 1L) pairs[[1]][1] else "Value (x)",
                  y = if (length(pairs) == 1L) pairs[[1]][2] else "Value (y)",
                  title = if (length(pairs) == 1L) "Joint posterior" else
                    "Joint posterior of pairs of parameters") +
    posterior_theme()
  if (!is.null(truth)) {
    truth <- stats::setNames(assert_numeric_vector(truth, "truth"), names(truth))
    known <- Filter(function(pr) all(pr %in% names(truth)), pairs)
    if (length(known) > 0L) {
      marks <- data.frame(pair = factor(vapply(known, pair_label, ""), levels = panel),
                          x = vapply(known, function(pr) truth[[pr[1]]], numeric(1)),
                          y = vapply(known, function(pr) truth[[pr[2]]], numeric(1)))
      p <- p + ggplot2::geom_point(data = marks, colour = "red", shape = 4, size = 3, stroke = 1.2)
    }
  }
  p
}

plot_posterior <- function(fit, truth) {
  theta <- lib_theta(fit$library)
  p <- if (scattered_library(fit$library)) posterior_density(fit, theta) else
    posterior_bars(fit, theta)
  if (!is.null(truth)) {
    truth <- stats::setNames(assert_numeric_vector(truth, "truth"), names(truth))
    if (is.null(names(truth)) || !all(names(truth) %in% names(theta))) {
      griddy_abort("`truth` must be named by theta columns (", show_some(names(theta)), ").")
    }
    marks <- data.frame(parameter = factor(names(truth), levels = names(theta)),
                        value = unname(truth))
    p <- p + ggplot2::geom_vline(data = marks, ggplot2::aes(xintercept = .data$value),
                                 colour = "red", linewidth = 0.7)
  }
  p
}

# A refined library's runs are many and unevenly spread, each weighed by its
# prior weight, and the values of a scattered design of several parameters
# do not repeat (most of a column's values are distinct, where a grid
# repeats each), so a bar per value says little: the draws' histogram is the
# posterior density. (With one parameter a run is a value: bars.)
scattered_library <- function(library) {
  theta <- lib_theta(library)
  inherits(library, "refined_library") ||
    (ncol(theta) > 1L &&
       any(vapply(theta, function(v) length(unique(v)) > nrow(theta) / 2, logical(1))))
}

# The marginal posterior of each parameter of a scattered design, honestly
# smooth: a kernel density over the library's runs, each weighted by its exact
# posterior probability, with Silverman's bandwidth for the effective number
# of runs 1 / sum(p_i^2) rather than the number of draws. A histogram of the
# draws shows the spikes of the few runs that carry the mass (a resolved fit
# can rest on some 20 effective runs out of 10,000) as if they were the shape.
posterior_density <- function(fit, theta) {
  weights <- exact_margins(fit)$run
  n_eff <- effective_count(weights)
  density_panels(weights, theta, n_eff) +
    ggplot2::labs(x = "Value", y = "Posterior density", title = "Posterior density",
                  subtitle = paste0("Runs weighted by their exact posterior,\n",
                                    "smoothed for ", format(n_eff, digits = 3),
                                    " effective runs (Silverman's bandwidth)")) +
    posterior_theme()
}

# One panel per parameter: the runs' values weighted by `weights`, smoothed
# (weighted_density()); plot() of a fit and of a stream.
density_panels <- function(weights, theta, n_eff = effective_count(weights)) {
  curves <- do.call(rbind, lapply(names(theta), function(p) {
    d <- weighted_density(theta[[p]], weights, n_eff)
    data.frame(parameter = factor(p, levels = names(theta)), value = d$x, density = d$y)
  }))
  ggplot2::ggplot(curves, ggplot2::aes(.data$value, .data$density)) +
    ggplot2::geom_area(fill = "steelblue", alpha = 0.35) +
    ggplot2::geom_line(colour = "steelblue4") +
    ggplot2::facet_wrap(ggplot2::vars(.data$parameter), scales = "free")
}

# stats::density() of values x weighted by w (summing to 1), with Silverman's
# rule of thumb at n_eff observations, over the range of x (the posterior has
# no mass outside the library).
weighted_density <- function(x, w, n_eff) {
  lib_range <- range(x)
  keep <- w > 0
  x <- x[keep]
  w <- w[keep] / sum(w[keep])
  spread <- sqrt(sum(w * (x - sum(w * x))^2))
  o <- order(x)
  quartiles <- x[o][pmin(findInterval(c(0.25, 0.75), cumsum(w[o])) + 1L, length(x))]
  iqr <- diff(quartiles) / 1.34
  bw <- 0.9 * (if (iqr > 0) min(spread, iqr) else spread) * n_eff^(-1 / 5)
  # one run carries it all: a narrow bump at that run
  if (!(bw > 0)) bw <- max(diff(lib_range), abs(x[1]), 1) * 1e-3
  # drawn where the runs with mass are, three bandwidths either side
  held <- range(x[w > max(w) * 1e-6])
  stats::density(x, weights = w, bw = bw, from = max(lib_range[1], held[1] - 3 * bw),
                 to = min(lib_range[2], held[2] + 3 * bw), n = 512)
}

# Room on the right for the last tick label of the rightmost panel, which
# ggplot centres on its break and would otherwise cut at the figure's edge.
posterior_theme <- function() {
  ggplot2::theme_bw() + ggplot2::theme(plot.margin = ggplot2::margin(5.5, 16, 5.5, 5.5))
}

posterior_bars <- function(fit, theta) {
  bars <- do.call(rbind, lapply(names(theta), function(p) {
    drawn <- theta[[p]][fit$draws$run]
    freq <- table(drawn) / length(drawn)
    value_bars(p, sort(unique(theta[[p]])), as.numeric(names(freq)), as.vector(freq))
  }))
  bars$parameter <- factor(bars$parameter, levels = names(theta))
  bar_panels(bars) +
    ggplot2::geom_point(data = library_ticks(theta, bars), ggplot2::aes(.data$value, 0),
                        shape = 15, size = 1, colour = "grey30") +
    ggplot2::labs(x = "Library value", y = "Posterior probability",
                  title = "Posterior over the library's values") +
    posterior_theme()
}

# Bars of probability `prob` at values `v` of parameter `p`, as wide as
# 0.45 of the library's smallest gap between its values `lib_values`.
value_bars <- function(p, lib_values, v, prob) {
  gaps <- diff(lib_values)
  half <- 0.45 * max(if (length(gaps)) min(gaps) else 0, diff(range(lib_values)) / 200,
                     abs(lib_values[1]) * 1e-3, 1e-12)
  data.frame(parameter = p, value = v, xmin = v - half, xmax = v + half, prob = prob)
}

# One panel per parameter of value_bars(); plot() of a fit and of a stream.
bar_panels <- function(bars) {
  ggplot2::ggplot(bars) +
    ggplot2::geom_rect(ggplot2::aes(xmin = .data$xmin, xmax = .data$xmax, ymin = 0,
                                    ymax = .data$prob), fill = "steelblue", colour = NA) +
    ggplot2::facet_wrap(ggplot2::vars(.data$parameter), scales = "free")
}

# The library's distinct values near the visited ones (two steps either side),
# marked on the axis as the thesis's figures do.
library_ticks <- function(theta, bars) {
  do.call(rbind, lapply(names(theta), function(p) {
    v <- sort(unique(theta[[p]]))
    seen <- range(bars$value[bars$parameter == p])
    lo <- max(1L, findInterval(seen[1], v) - 2L)
    hi <- min(length(v), findInterval(seen[2], v) + 2L)
    data.frame(parameter = factor(p, levels = names(theta)), value = v[lo:hi])
  }))
}

plot_ppc <- function(fit, level = 0.95, discrepancy = has_discrepancy(fit), ...) {
  # settings the library does not hold: predicted beside its own (fit-plot-new.R)
  newdata <- list(...)$newdata
  lib <- predicted_library(fit)
  if (!is.null(new_setting_rows(lib, newdata))) {
    return(plot_ppc_new(fit, level = level, discrepancy = discrepancy, ...))
  }
  pred <- predict(fit, level = level, discrepancy = discrepancy, ...)
  place <- cell_places(lib, pred[[setting_column(lib)]])
  pred <- cbind(place$cells, pred[c("observed", "mean", "lower", "upper", "pred_lower",
                                    "pred_upper")])
  p <- ggplot2::ggplot(pred, ggplot2::aes(x = .data$position))
  if (lib_n_t(lib) == 1L) {
    p <- p +
      ggplot2::geom_linerange(ggplot2::aes(ymin = .data$pred_lower, ymax = .data$pred_upper),
                              colour = "grey60", linewidth = 2) +
      ggplot2::geom_pointrange(ggplot2::aes(y = .data$mean, ymin = .data$lower,
                                            ymax = .data$upper), colour = "steelblue") +
      ggplot2::geom_point(ggplot2::aes(y = .data$observed), colour = "black", shape = 4,
                          size = 2.5, na.rm = TRUE)
  } else {
    p <- p +
      ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$pred_lower, ymax = .data$pred_upper),
                           fill = "grey80") +
      ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lower, ymax = .data$upper),
                           fill = "steelblue", alpha = 0.5) +
      ggplot2::geom_line(ggplot2::aes(y = .data$mean), colour = "steelblue") +
      ggplot2::geom_point(ggplot2::aes(y = .data$observed), size = 0.6, na.rm = TRUE) +
      ggplot2::facet_wrap(ggplot2::vars(.data$setting), scales = "free_y")
  }
  p + place$axis +
    ggplot2::labs(x = place$title, y = "Output", title = "Posterior predictive check",
                  subtitle = wrap_subtitle(c(
                    "Black: field data (missing cells left out).",
                    paste0("Blue: simulator", if (isTRUE(discrepancy)) " + discrepancy",
                           " at the drawn runs"),
                    paste0("(mean, ", format(100 * level), "% band). Grey: with fitted noise.")))) +
    ggplot2::theme_bw()
}

# Where the outputs of a table of library cells (predict(),
# discrepancy_posterior(); `setting` their settings' rows) go on a plot:
# `cells`, a data.frame of `setting` (the setting's label, "load = 6", the
# panel) and `position` on the horizontal axis: t when the library has
# several outputs per setting; with one, the setting itself, at its x
# column's value (one x column) or its label (several; a discrete axis).
# `title` is the axis's title and `axis` its scale.
cell_places <- function(lib, setting) {
  labels <- setting_labels(lib)
  label <- factor(labels[setting], levels = labels)
  x <- lib_x(lib)
  if (lib_n_t(lib) > 1L) {
    t <- rep(lib_t(lib), length.out = length(setting))
    return(list(cells = data.frame(setting = label, position = t), title = "t",
                # few breaks: several panels side by side leave each little width
                axis = ggplot2::scale_x_continuous(
                  n.breaks = 4, guide = ggplot2::guide_axis(check.overlap = TRUE))))
  }
  if (!is.null(x) && ncol(x) == 1L) {
    return(list(cells = data.frame(setting = label, position = x[[1]][setting]),
                title = names(x), axis = NULL))
  }
  list(cells = data.frame(setting = label, position = label),
       title = if (is.null(x)) NULL else "x setting", axis = setting_axis(length(labels)))
}

# A discrete axis of settings' labels ("load = 2, speed = 10"): a few side
# by side, one column a line ("load = 2" over "speed = 10"), which a 6-inch
# figure holds; more, each label on one line turned upright.
setting_axis <- function(n_settings) {
  if (n_settings <= 8L) {
    return(ggplot2::scale_x_discrete(labels = function(l) gsub(", ", "\n", l, fixed = TRUE)))
  }
  ggplot2::scale_x_discrete(guide = ggplot2::guide_axis(angle = 90))
}

# ggplot2 does not wrap a subtitle: a line longer than the figure is cut at
# its edge. Each element of `lines` starts a line (the callers break where
# the sense does), wrapped at `width` characters, which theme_bw()'s 11-point
# text draws in about 4.5 inches: a 6-inch figure holds that beside its y axis.
wrap_subtitle <- function(lines, width = 60L) {
  paste(unlist(lapply(lines, strwrap, width = width)), collapse = "\n")
}

# The discrepancy's posterior mean and band against t, one panel per x
# setting (for one output per setting, against the setting: its x column's
# value or its label, cell_places()), with the residuals of the field data
# from the simulator's posterior mean outputs. One noise group: the panels
# share the y axis, so the gap's size compares across settings; several
# (maybe other units): each panel its own.
plot_discrepancy <- function(fit, level = 0.95, ...) {
  post <- discrepancy_posterior(fit, level = level, ...)
  lib <- fit$library
  replicated <- fit$n_obs > sum(!is.na(fit$y_field))
  place <- cell_places(lib, post[[setting_column(lib)]])
  post <- cbind(place$cells, post[c("residual", "mean", "lower", "upper")])
  p <- ggplot2::ggplot(post, ggplot2::aes(x = .data$position)) +
    ggplot2::geom_hline(yintercept = 0, linetype = "dashed", colour = "grey40")
  if (lib_n_t(lib) == 1L) {
    p <- p +
      ggplot2::geom_pointrange(ggplot2::aes(y = .data$mean, ymin = .data$lower,
                                            ymax = .data$upper), colour = "firebrick") +
      ggplot2::geom_point(ggplot2::aes(y = .data$residual), colour = "black", shape = 4,
                          size = 2.5, na.rm = TRUE)
  } else {
    several_groups <- length(fit$setup$pattern$labels) > 1L
    p <- p +
      ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lower, ymax = .data$upper),
                           fill = "firebrick", alpha = 0.25) +
      ggplot2::geom_line(ggplot2::aes(y = .data$mean), colour = "firebrick") +
      ggplot2::geom_point(ggplot2::aes(y = .data$residual), size = 0.8, na.rm = TRUE) +
      ggplot2::facet_wrap(ggplot2::vars(.data$setting),
                          scales = if (several_groups) "free_y" else "fixed")
  }
  p + place$axis +
    ggplot2::labs(x = place$title, y = "Discrepancy (data minus simulator)",
                  title = "Where the simulator misses the data",
                  subtitle = wrap_subtitle(c(
                    paste0("Red: the discrepancy's posterior mean, ", format(100 * level),
                           "% band."),
                    paste0("Black: data", if (replicated) " (replicates' means)",
                           " minus the simulator's"),
                    "posterior mean. Dashed: no gap."))) +
    posterior_theme()
}

# "height = 10, speed = 20" for each x setting.
setting_labels <- function(lib) {
  if (is.null(lib_x(lib))) {
    return("single setting")
  }
  labels <- do.call(paste, c(Map(function(n, v) paste(n, "=", format(v, digits = 4)),
                                 names(lib_x(lib)), lib_x(lib)), sep = ", "))
  make.unique(labels)
}
