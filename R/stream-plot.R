#' Plot a streaming calibration or a model choice
#'
#' `plot()` of a [griddy_stream()] draws the exact posterior of each
#' \eqn{\theta} parameter given the data so far, one panel per parameter:
#' over a library whose values repeat (a grid), a bar per library value
#' holding its posterior probability; over a scattered design, the runs
#' weighted by their posterior probability and smoothed (as
#' `plot(fit, "posterior")` does). Before any measurement it draws the
#' prior (the run weights).
#'
#' `plot()` of a [stream_models()] draws each model's posterior probability
#' as the measurements arrived (from its history, starting at the models'
#' probabilities before the first update), or, before any update, the
#' current probabilities as bars.
#'
#' `plot(stream, "ppc")` draws the stream's predictions
#' ([predict.griddy_stream()]) against its measurements, as
#' `plot(fit, "ppc")` does for a fit; with `newdata` and `simulator`, at
#' settings the library does not hold too.
#'
#' @param x A [griddy_stream()] or a [stream_models()].
#' @param type For a stream: `"posterior"` (the default) or `"ppc"`.
#' @param ... For a stream's `"ppc"`, passed to [predict.griddy_stream()]
#'   (`level`, `ndraws`, `seed`, `newdata`, `simulator`, `run_mass`);
#'   otherwise ignored.
#' @return A ggplot object (print it to draw it).
#' @seealso [griddy_stream()], [stream_models()]
#' @examples
#' ex <- griddy_example()
#' s <- update(griddy_stream(ex$library), y = ex$field)
#' plot(s)
#' plot(s, "ppc", ndraws = 200, seed = 1)
#' rival <- sim_library(ex$library$theta, 0.9 * ex$library$y, x = ex$library$x,
#'                      t = ex$library$t)
#' m <- stream_models(spring = griddy_stream(ex$library), damped = griddy_stream(rival))
#' m <- update(m, y = ex$field)
#' plot(m)
#' @name plot.griddy_stream
NULL

#' @rdname plot.griddy_stream
#' @export
plot.griddy_stream <- function(x, type = c("posterior", "ppc"), ...) {
  type <- assert_choice(type, "type", c("posterior", "ppc"), vector_default = TRUE)
  if (type == "ppc") return(plot_ppc(x, discrepancy = FALSE, ...))
  state <- x$state
  n <- nobs(x)
  run <- if (n > 0L) stream_margins(x)$run else normalise_log(state$log_prior_run)
  theta <- lib_theta(state$library)
  what <- if (n > 0L) paste0("Exact posterior after ", n, " measurement(s)") else
    "Prior (no measurement yet)"
  p <- if (scattered_library(state$library)) {
    stream_density_plot(run, theta)
  } else {
    stream_bar_plot(run, theta)
  }
  p + ggplot2::labs(title = what) + posterior_theme()
}

# A grid library: each parameter's library values with the probability of
# the runs at them (exact, summed over the other parameters).
stream_bar_plot <- function(run, theta) {
  bars <- do.call(rbind, lapply(names(theta), function(p) {
    prob <- tapply(run, theta[[p]], sum)
    v <- as.numeric(names(prob))
    value_bars(p, v, v, as.vector(prob))
  }))
  bars$parameter <- factor(bars$parameter, levels = names(theta))
  bar_panels(bars) +
    ggplot2::labs(x = "Library value", y = "Probability",
                  subtitle = "Probability of each library value, summed over the runs at it")
}

# A scattered design: the runs' values weighted by their probability,
# smoothed for the effective number of runs (density_panels()).
stream_density_plot <- function(run, theta) {
  density_panels(run, theta) +
    ggplot2::labs(x = "Value", y = "Density",
                  subtitle = paste0("Runs weighted by their probability, smoothed for ",
                                    format(effective_count(run), digits = 3),
                                    " effective runs"))
}

#' @rdname plot.griddy_stream
#' @export
plot.griddy_stream_models <- function(x, ...) {
  state <- x$state
  models <- names(state$streams)
  h <- as.data.frame(x)
  forgetting <- if (state$forgetting < 1) paste0("Forgetting ", format(state$forgetting)) else
    "No forgetting: the exact posterior probabilities"
  if (nrow(h) == 0L) {
    now <- data.frame(model = factor(models, levels = models), prob = exp(state$log_prob))
    return(ggplot2::ggplot(now, ggplot2::aes(.data$model, .data$prob)) +
             ggplot2::geom_col(fill = "steelblue") +
             ggplot2::scale_y_continuous(limits = c(0, 1)) +
             ggplot2::labs(x = "Model", y = "Probability", title = "Model probabilities",
                           subtitle = "No measurement yet: the prior") +
             ggplot2::theme_bw())
  }
  start <- if (is.null(state$initial_prob)) rep(NA_real_, length(models)) else state$initial_prob
  long <- do.call(rbind, lapply(seq_along(models), function(m) {
    data.frame(step = c(0L, h$step), model = models[m],
               prob = c(start[m], h[[paste0("prob_", models[m])]]))
  }))
  long <- long[!is.na(long$prob), ]
  long$model <- factor(long$model, levels = models)
  ggplot2::ggplot(long, ggplot2::aes(.data$step, .data$prob, colour = .data$model)) +
    ggplot2::geom_step(linewidth = 0.6) +
    ggplot2::scale_y_continuous(limits = c(0, 1)) +
    ggplot2::labs(x = "Measurements taken", y = "Posterior probability", colour = "Model",
                  title = "Model probabilities as the measurements arrived",
                  subtitle = forgetting) +
    ggplot2::theme_bw()
}
