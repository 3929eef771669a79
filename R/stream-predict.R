#' Predictions from a stream's posterior
#'
#' The simulator outputs under a [griddy_stream()]'s exact posterior over
#' runs (the data so far), and the same with the noise of a new
#' measurement, at the library's settings or, with `simulator`, at x
#' settings the library does not hold.
#'
#' A stream holds the exact posterior over (run, correlation grid point)
#' and the conditional law of each \eqn{\tau}, so no Markov chain enters:
#' `mean`, `lower` and `upper` are the posterior mean and weighted
#' quantiles of the runs' outputs, exact over the runs (those carrying
#' `run_mass` at new settings); `pred_lower` and `pred_upper` are the
#' quantiles of `ndraws` independent draws ([stream_draws()]) of a run, a
#' grid point and \eqn{\tau}, each with noise \eqn{N(0, \tau^{-1} R_t)} at
#' its \eqn{\rho_t} added (each noise group at its own \eqn{\tau};
#' independent across settings, since a stream's \eqn{\rho_x} is 0).
#' At new settings the simulator runs at the most probable distinct runs
#' carrying `run_mass` of the posterior, through the runner of
#' [simulate_library()] (any [future::plan()]), as
#' [predict.griddy_fit()] runs it; noise groups must then depend on t only.
#' A stream has no discrepancy (its update is one term per measurement),
#' and takes simulated runs only, so there is no emulator to predict new
#' settings without a simulator: that is an error of class
#' `griddy_error_prediction`.
#'
#' @param object A [griddy_stream()] with at least one measurement.
#' @inheritParams predict.griddy_fit
#' @return A data.frame as [predict.griddy_fit()]'s: `x` (the setting's
#'   library row, `NA` at new settings; `setting` when an x column is named
#'   `x`), the x columns, `t`, `observed` (the mean of the stream's
#'   measurements at the cell, `NA` where none), `mean`, `lower`, `upper`,
#'   `pred_lower`, `pred_upper`.
#' @seealso [predict.griddy_fit()], [stream_draws()]
#' @examples
#' x <- data.frame(x = seq(0.2, 4, length.out = 11))
#' theta <- data.frame(theta = seq(0.3, 1, by = 0.0025))
#' lib <- sim_library(theta, outer(theta$theta, x$x), x = x)
#' set.seed(1)
#' s <- update(griddy_stream(lib), y = field_data(matrix(0.65 * x$x + rnorm(11, sd = 0.05)),
#'                                                x = x))
#' predict(s, newdata = data.frame(x = c(2, 6)), seed = 1,
#'         simulator = function(theta, x) outer(theta$theta, x$x))
#' @export
predict.griddy_stream <- function(object, newdata = NULL, level = 0.95, ndraws = 1000,
                                  seed = NULL, simulator = NULL, run_mass = 0.999, ...) {
  assert_level(level)
  ndraws <- assert_count(ndraws, "ndraws")
  seed <- assert_seed(seed)
  state <- object$state
  lib <- state$library
  p <- stream_margins(object)$run
  hit <- new_setting_rows(lib, newdata)
  if (is.null(hit)) {
    settings <- predict_settings(lib, newdata)
    return(with_seed(seed, stream_predict_at(object, p, settings, level, ndraws)))
  }
  new <- which(is.na(hit))
  x_new <- as.data.frame(as_numeric_matrix(newdata[new, names(lib_x(lib)), drop = FALSE],
                                           "newdata"))
  rownames(x_new) <- NULL
  if (!is.function(simulator)) {
    griddy_abort(
      "`newdata` row(s) ", show_some(new), " (", show_some(setting_text(lib, x_new)),
      ") are not x settings of the stream's library, which holds the simulator's outputs ",
      "at its own settings only; a stream takes simulated runs only, so there is no ",
      "emulator over x either. To predict there, pass `simulator = function(theta, x)` ",
      "(see ?predict.griddy_fit); received ", class(simulator)[1], ".",
      class = c("prediction", "input"))
  }
  assert_run_mass(run_mass)
  old <- which(!is.na(hit))
  parts <- list()
  if (length(old) > 0L) {
    parts$old <- with_seed(seed, stream_predict_at(object, p, hit[old], level, ndraws))
  }
  parts$new <- with_seed(seed, stream_predict_new(object, p, x_new, level, ndraws, simulator,
                                                  run_mass))
  n_t <- lib_n_t(lib)
  out <- do.call(rbind, unname(parts))
  out <- out[order(rep(c(old, new), each = n_t)), , drop = FALSE]
  rownames(out) <- NULL
  out
}

# At the library's settings `settings` (rows of its x): exact mean and
# bands over every run with mass, noisy draws for the predictive band.
stream_predict_at <- function(stream, p, settings, level, ndraws) {
  state <- stream$state
  lib <- state$library
  n_t <- lib_n_t(lib)
  cols <- as.vector(outer(seq_len(n_t), (settings - 1L) * n_t, "+"))
  runs <- which(p > 0)
  Y <- state$outputs[runs, cols, drop = FALSE]
  w <- p[runs] / sum(p[runs])
  probs <- c((1 - level) / 2, 1 - (1 - level) / 2)
  bounds <- apply(Y, 2, weighted_quantile, w = w, probs = probs)
  d <- stream_draws(stream, ndraws)
  noisy <- state$outputs[d$run, cols, drop = FALSE] +
    stream_noise(stream, d, state$group[cols], length(settings))
  pred <- apply(noisy, 2, stats::quantile, probs = probs, names = FALSE)
  sums <- tabulate(state$data$column, ncol(state$outputs))
  totals <- vapply(split(state$data$y, factor(state$data$column,
                                              levels = seq_len(ncol(state$outputs)))),
                   sum, numeric(1))
  observed <- ifelse(sums > 0, totals / pmax(sums, 1), NA_real_)[cols]
  cbind(setting_cells(lib, settings), observed = observed, mean = colSums(Y * w),
        lower = bounds[1, ], upper = bounds[2, ], pred_lower = pred[1, ],
        pred_upper = pred[2, ])
}

# At new settings `x_new`: the simulator at the runs carrying `run_mass`
# of the posterior, the draws of those runs for the predictive band.
stream_predict_new <- function(stream, p, x_new, level, ndraws, simulator, run_mass) {
  state <- stream$state
  lib <- state$library
  n_t <- lib_n_t(lib)
  groups <- stream_new_groups(state, nrow(x_new))
  visited <- which(p > 0)
  o <- visited[order(-p[visited], visited)]
  runs <- sort(o[seq_len(which(cumsum(p[o]) >= run_mass * sum(p) - 1e-12)[1])])
  Y <- simulate_at(simulator, lib_theta(lib)[runs, , drop = FALSE], x_new, nrow(x_new) * n_t)
  w <- p[runs] / sum(p[runs])
  probs <- c((1 - level) / 2, 1 - (1 - level) / 2)
  bounds <- apply(Y, 2, weighted_quantile, w = w, probs = probs)
  # exact draws, those of the runs simulated (all but the left-out mass)
  d <- stream_draws(stream, ndraws)
  d <- d[d$run %in% runs, , drop = FALSE]
  noisy <- Y[match(d$run, runs), , drop = FALSE] + stream_noise(stream, d, groups, nrow(x_new))
  pred <- apply(noisy, 2, stats::quantile, probs = probs, names = FALSE)
  cells <- stats::setNames(data.frame(rep(NA_integer_, nrow(x_new) * n_t)), setting_column(lib))
  cells <- cbind(cells, x_new[rep(seq_len(nrow(x_new)), each = n_t), , drop = FALSE],
                 t = rep(lib_t(lib), nrow(x_new)))
  rownames(cells) <- NULL
  cbind(cells, observed = NA_real_, mean = colSums(Y * w), lower = bounds[1, ],
        upper = bounds[2, ], pred_lower = pred[1, ], pred_upper = pred[2, ])
}

# The noise group of each cell at `n_new` new settings: its t's, which must
# be that t's group at every library setting.
stream_new_groups <- function(state, n_new) {
  groups_by_t(state$group, lib_n_t(state$library), n_new, "stream")
}

# Noise of a new measurement for the draws `d` (stream_draws()) at `n_set`
# settings of the library's t values, the cells' noise groups `group`:
# N(0, tau_k^-1 R_t) at each draw's rho_t within a setting, independent
# across settings and groups.
stream_noise <- function(stream, d, group, n_set) {
  state <- stream$state
  lib <- state$library
  n <- nrow(d)
  tau <- as.matrix(d[grep("^tau", names(d))])
  rho <- if ("rho_t" %in% names(d)) d$rho_t else rep(0, n)
  out <- matrix(0, n, length(group))
  for (r in unique(rho)) {
    rows <- which(rho == r)
    phi <- ar1_phi(lib_t(lib), r)
    for (k in seq_len(ncol(tau))) {
      Z <- matrix(stats::rnorm(length(rows) * length(group)), length(rows))
      noise <- ar1_colour_rows_cpp(Z, phi, n_set) / sqrt(tau[rows, k])
      cols <- which(group == k)
      out[rows, cols] <- noise[, cols]
    }
  }
  out
}
