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
  pieces <- stream_prediction_pieces(object, newdata, ndraws, seed, simulator, run_mass)
  prediction_from_pieces(pieces, level)
}

# What predict() of a stream summarises, without summarising it: the cells
# asked for in one or two pieces (the library's settings, the new ones), each
# list(cells = the cell columns with `observed`, Y = the outputs of the runs
# with mass there, w = their posterior weights, noisy = ndraws exact draws of
# a new measurement), and `order`, the rows of newdata's order. A model
# choice mixes its models' pieces (predict.griddy_stream_models()).
stream_prediction_pieces <- function(stream, newdata, ndraws, seed, simulator, run_mass) {
  lib <- stream$state$library
  p <- stream_margins(stream)$run
  hit <- new_setting_rows(lib, newdata)
  if (is.null(hit)) {
    settings <- predict_settings(lib, newdata)
    return(list(pieces = list(with_seed(seed, stream_piece_at(stream, p, settings, ndraws))),
                order = NULL))
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
  pieces <- list()
  if (length(old) > 0L) {
    pieces$old <- with_seed(seed, stream_piece_at(stream, p, hit[old], ndraws))
  }
  pieces$new <- with_seed(seed, stream_piece_new(stream, p, x_new, ndraws, simulator,
                                                 run_mass))
  list(pieces = unname(pieces), order = order(rep(c(old, new), each = lib_n_t(lib))))
}

# predict()'s table from stream_prediction_pieces(): the weighted mean and
# quantiles of the outputs, the quantiles of the noisy draws, in newdata's
# order.
prediction_from_pieces <- function(pieces, level) {
  probs <- c((1 - level) / 2, 1 - (1 - level) / 2)
  out <- do.call(rbind, lapply(pieces$pieces, function(piece) {
    w <- piece$w / sum(piece$w)
    bounds <- apply(piece$Y, 2, weighted_quantile, w = w, probs = probs)
    pred <- apply(piece$noisy, 2, stats::quantile, probs = probs, names = FALSE)
    cbind(piece$cells, mean = colSums(piece$Y * w), lower = bounds[1, ], upper = bounds[2, ],
          pred_lower = pred[1, ], pred_upper = pred[2, ])
  }))
  if (!is.null(pieces$order)) out <- out[pieces$order, , drop = FALSE]
  rownames(out) <- NULL
  out
}

# At the library's settings `settings` (rows of its x): every run with mass,
# and noisy draws for the predictive band.
stream_piece_at <- function(stream, p, settings, ndraws) {
  state <- stream$state
  lib <- state$library
  n_t <- lib_n_t(lib)
  cols <- as.vector(outer(seq_len(n_t), (settings - 1L) * n_t, "+"))
  runs <- which(p > 0)
  d <- stream_draws(stream, ndraws)
  noisy <- state$outputs[d$run, cols, drop = FALSE] +
    stream_noise(stream, d, state$group[cols], length(settings))
  sums <- tabulate(state$data$column, ncol(state$outputs))
  totals <- vapply(split(state$data$y, factor(state$data$column,
                                              levels = seq_len(ncol(state$outputs)))),
                   sum, numeric(1))
  observed <- ifelse(sums > 0, totals / pmax(sums, 1), NA_real_)[cols]
  list(cells = cbind(setting_cells(lib, settings), observed = observed),
       Y = state$outputs[runs, cols, drop = FALSE], w = p[runs], noisy = noisy)
}

# At new settings `x_new`: the simulator at the runs carrying `run_mass`
# of the posterior, the draws of those runs for the predictive band.
stream_piece_new <- function(stream, p, x_new, ndraws, simulator, run_mass) {
  state <- stream$state
  lib <- state$library
  n_t <- lib_n_t(lib)
  groups <- stream_new_groups(state, nrow(x_new))
  visited <- which(p > 0)
  o <- visited[order(-p[visited], visited)]
  runs <- sort(o[seq_len(which(cumsum(p[o]) >= run_mass * sum(p) - 1e-12)[1])])
  Y <- simulate_at(simulator, lib_theta(lib)[runs, , drop = FALSE], x_new, nrow(x_new) * n_t)
  # exact draws, those of the runs simulated (all but the left-out mass)
  d <- stream_draws(stream, ndraws)
  d <- d[d$run %in% runs, , drop = FALSE]
  noisy <- Y[match(d$run, runs), , drop = FALSE] + stream_noise(stream, d, groups, nrow(x_new))
  cells <- stats::setNames(data.frame(rep(NA_integer_, nrow(x_new) * n_t)), setting_column(lib))
  cells <- cbind(cells, x_new[rep(seq_len(nrow(x_new)), each = n_t), , drop = FALSE],
                 t = rep(lib_t(lib), nrow(x_new)))
  rownames(cells) <- NULL
  list(cells = cbind(cells, observed = NA_real_), Y = Y, w = p[runs], noisy = noisy)
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

#' Predictions averaged over a model choice
#'
#' The prediction of a [stream_models()] choice: each model's stream
#' predicts as [predict.griddy_stream()] does, and the models' predictions
#' are mixed by their current posterior probabilities (Bayesian model
#' averaging; with `forgetting` < 1, the discounted probabilities the choice
#' holds). `mean` is the probability-weighted mean, `lower` and `upper` the
#' quantiles of the mixture over every model's runs (each run weighted by
#' its model's probability times its posterior mass in that model), and
#' `pred_lower`, `pred_upper` the quantiles of `ndraws` draws of a new
#' measurement, each from a model drawn by its probability. While the
#' models disagree, the band spans both; once one model holds the
#' probability, the prediction is that model's.
#'
#' At x settings no model's library holds, each model's simulator runs at
#' its own posterior runs: `simulator` is then one `function(theta, x)` for
#' every model (models that share a simulator), or a named list of them, one
#' per model (`names(m$streams)`). The models' libraries must hold the same
#' x settings and t values (as the same measurements reach them all); if
#' not, the prediction is an error of class `griddy_error_unsupported`.
#'
#' @param object A [stream_models()] choice with at least one measurement.
#' @param simulator `NULL`, a `function(theta, x)` (see
#'   [predict.griddy_fit()]) used for every model, or a list of them named
#'   by the models.
#' @inheritParams predict.griddy_fit
#' @return A data.frame as [predict.griddy_stream()]'s.
#' @seealso [stream_models()], [predict.griddy_stream()], [next_measurement()]
#' @examples
#' ex <- griddy_example()
#' lib <- ex$library
#' rival <- sim_library(lib$theta, 0.9 * lib$y, x = lib$x, t = lib$t)
#' m <- stream_models(spring = griddy_stream(lib), damped = griddy_stream(rival))
#' m <- update(m, y = ex$field)
#' head(predict(m, seed = 1))
#' @export
predict.griddy_stream_models <- function(object, newdata = NULL, level = 0.95, ndraws = 1000,
                                         seed = NULL, simulator = NULL, run_mass = 0.999,
                                         ...) {
  assert_level(level)
  ndraws <- assert_count(ndraws, "ndraws")
  seed <- assert_seed(seed)
  state <- object$state
  models <- names(state$streams)
  simulators <- model_simulators(simulator, models)
  prob <- exp(state$log_prob)
  per_model <- Map(function(stream, sim) {
    stream_prediction_pieces(stream, newdata, ndraws, seed, sim, run_mass)
  }, state$streams, simulators)
  assert_same_cells(per_model, models)
  # the model of each draw of a new measurement, by its probability
  n_from <- with_seed(seed, as.vector(stats::rmultinom(1L, ndraws, prob)))
  mixed <- lapply(seq_along(per_model[[1]]$pieces), function(k) {
    pieces <- lapply(per_model, function(m) m$pieces[[k]])
    list(cells = pieces[[1]]$cells,
         Y = do.call(rbind, lapply(pieces, `[[`, "Y")),
         w = unlist(Map(function(piece, pm) pm * piece$w / sum(piece$w), pieces, prob)),
         noisy = do.call(rbind, Map(function(piece, n) {
           piece$noisy[seq_len(min(n, nrow(piece$noisy))), , drop = FALSE]
         }, pieces, n_from)))
  })
  prediction_from_pieces(list(pieces = mixed, order = per_model[[1]]$order), level)
}

# One simulator per model: NULL for all, one function for all, or a list
# named by the models.
model_simulators <- function(simulator, models) {
  if (is.null(simulator) || is.function(simulator)) {
    return(stats::setNames(rep(list(simulator), length(models)), models))
  }
  if (!is.list(simulator) || is.null(names(simulator)) ||
      !setequal(names(simulator), models) || !all(vapply(simulator, is.function, TRUE))) {
    griddy_abort("`simulator` must be NULL, a function(theta, x) for every model, or a list of ",
                 "functions named by the models (", paste(models, collapse = ", "), ").",
                 class = "input")
  }
  simulator[models]
}

# The models' predictions mix cell by cell only when they are of the same
# cells: the same x settings and t values in the same order.
assert_same_cells <- function(per_model, models) {
  # the cells' x columns and t: all but the setting's library row (first) and `observed`
  key <- function(m) {
    lapply(m$pieces, function(piece) piece$cells[-c(1L, ncol(piece$cells))])
  }
  first <- key(per_model[[1]])
  same <- vapply(per_model, function(m) {
    identical(m$order, per_model[[1]]$order) && isTRUE(all.equal(key(m), first))
  }, TRUE)
  if (!all(same)) {
    griddy_abort("predict() of a model choice mixes its models cell by cell, so their libraries ",
                 "must hold the same x settings and t values; model(s) ",
                 paste(models[!same], collapse = ", "), " differ from ", models[1], ".",
                 class = "unsupported")
  }
}
