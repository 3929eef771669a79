#' Choose between models as measurements arrive
#'
#' Several [griddy_stream()]s over different libraries (candidate
#' simulators, or a simulator with and without an effect) take the same
#' measurements; after each one, the posterior probability of each model
#' is updated from its one-step predictive density, the ratio of its
#' running evidences ([logLik()][logLik.griddy_stream], one more pass over
#' the runs): \eqn{p(y_k \mid y_{1:k-1}, M) = Z_k(M) / Z_{k-1}(M)}.
#'
#' **Following a change of regime: dynamic model averaging.** With
#' `forgetting` \eqn{\alpha = 1} the probabilities are the exact Bayesian
#' ones, \eqn{p(M \mid y_{1:k}) \propto p(M) Z_k(M)}: after much evidence for
#' one model they take as much evidence again to turn. With
#' \eqn{\alpha < 1} they follow Raftery, Karny and Ettler (2010): before
#' each measurement the probabilities are flattened,
#' \eqn{p_{k|k-1}(M) \propto p_{k-1}(M)^\alpha}, then multiplied by the
#' predictive density, \eqn{p_k(M) \propto p_{k|k-1}(M) p(y_k \mid
#' y_{1:k-1}, M)}. This is the exact posterior of a model index that may
#' switch between measurements (a hidden Markov chain on the models) in the
#' approximation the authors make, and amounts to an exponentially
#' discounted evidence: \eqn{\log p_k(M) = \sum_j \alpha^{k-j} \log p(y_j
#' \mid y_{1:j-1}, M)} + const; the effective memory is about \eqn{1 / (1 -
#' \alpha)} measurements (\eqn{\alpha = 0.99}: the last hundred or so).
#' Each model's own posterior over its runs is not discounted: the
#' parameters are taken as fixed, the model's adequacy as what changes
#' (for a drum test, the tyre stays the same tyre while the cleat height
#' changes). The probabilities are kept as logarithms, so no model's
#' probability reaches machine zero.
#'
#' The streams are updated in place (see [griddy_stream()]): give each
#' `stream_models()` streams of its own, or a stream shared by two of them
#' takes every measurement twice. The same stream given for two models is
#' refused (an error of class `griddy_error_duplicate_stream`), and so is an
#' update after a stream was updated outside the model choice (class
#' `griddy_error_stream_changed`). [plot()][plot.griddy_stream_models] draws
#' the probabilities as the data arrived.
#'
#' **An update reaches every model or none.** The measurements of one
#' `update()` are first matched to every model's library; if a stream then
#' refuses one (an AR(1) replicate, a misfit that overflows), every stream
#' and the probabilities are put back as they were before the call and the
#' error is raised, so the models always hold the same data.
#'
#' @param ... For `stream_models()`: named [griddy_stream()]s (at least two), one per model, each
#'   holding the same measurements so far (usually none).
#' @param prior Prior model probabilities (one per model; `NULL`: equal).
#' @param forgetting The flattening exponent \eqn{\alpha} in (0, 1]; 1 (the
#'   default) gives the exact posterior model probabilities.
#' @return A `griddy_stream_models` (a reference object, as a stream is):
#'   update it with [update()][update.griddy_stream_models]; `as.data.frame()`
#'   gives the history, `logLik()` each model's log evidence, and
#'   `$streams` the streams themselves.
#' @references Raftery, A. E., Karny, M. and Ettler, P. (2010). Online
#'   prediction under model uncertainty via dynamic model averaging:
#'   application to a cold rolling mill. *Technometrics* 52(1), 52-66.
#'   \doi{10.1198/TECH.2009.08104}
#' @seealso [griddy_stream()]
#' @examples
#' ex <- griddy_example()
#' lib <- ex$library
#' # a rival model: the same runs with their responses damped by 10%
#' rival <- sim_library(lib$theta, 0.9 * lib$y, x = lib$x, t = lib$t)
#' m <- stream_models(spring = griddy_stream(lib), damped = griddy_stream(rival))
#' m <- update(m, y = ex$field)
#' tail(as.data.frame(m), 3)
#' @export
stream_models <- function(..., prior = NULL, forgetting = 1) {
  streams <- list(...)
  if (length(streams) < 2L || is.null(names(streams)) || any(names(streams) == "") ||
      anyDuplicated(names(streams))) {
    griddy_abort("`...` must be two or more streams with distinct names, one per model.")
  }
  for (m in names(streams)) assert_stream(streams[[m]], m)
  assert_distinct_streams(streams)
  n <- vapply(streams, nobs, integer(1))
  if (any(n != n[1])) {
    griddy_abort("The streams must hold the same measurements so far; they hold ",
                 show_some(n), ".")
  }
  prior <- if (is.null(prior)) rep(1, length(streams)) else
    assert_number(prior, "prior", len = length(streams), lower = 0)
  if (sum(prior) <= 0) griddy_abort("`prior` must have a positive sum.")
  forgetting <- assert_number(forgetting, "forgetting", lower = 0, lower_open = TRUE,
                              upper = 1)
  state <- new.env(parent = emptyenv())
  state$streams <- streams
  state$n_taken <- n[[1]]  # what every stream holds, unless updated behind our back
  state$forgetting <- forgetting
  state$log_evidence <- vapply(streams, function(s) as.numeric(logLik(s)), numeric(1))
  if (anyNA(state$log_evidence)) {
    griddy_abort("Every stream needs a proper prior on tau (a positive rate) for its ",
                 "evidence.", class = "improper_prior")
  }
  state$log_prob <- normalise_log_prob(log(prior / sum(prior)) +
                                         if (n[1] > 0L) state$log_evidence else 0)
  state$initial_prob <- exp(state$log_prob)  # where plot()'s history starts
  state$history <- list()
  structure(list(state = state), class = "griddy_stream_models")
}

#' @rdname stream_models
#' @param object A `griddy_stream_models`.
#' @param y,x,t The measurements, as for [update.griddy_stream()] (a
#'   [field_data()] is taken setting by setting, in increasing t); every
#'   stream takes them one at a time, and the model probabilities are
#'   updated after each. `...` is ignored.
#' @export
update.griddy_stream_models <- function(object, y, x = NULL, t = NULL, ...) {
  state <- object$state
  assert_streams_in_step(state)
  libraries <- lapply(state$streams, function(s) s$state$library)
  cells <- lapply(libraries, stream_cells, y = y, x = x, t = t)
  first <- libraries[[1]]
  saved <- models_snapshot(state)
  withCallingHandlers({
    n_t <- lib_n_t(first)
    for (m in seq_along(cells[[1]]$column)) {
      column <- cells[[1]]$column[m]
      x_m <- if (lib_n_x(first) > 1L) lib_x(first)[(column - 1L) %/% n_t + 1L, , drop = FALSE]
      t_m <- lib_t(first)[(column - 1L) %% n_t + 1L]
      models_add(state, cells[[1]]$y[m], x_m, t_m)
    }
  }, error = function(e) models_restore(state, saved))
  object
}

# The same stream (one environment) under two names would take every
# measurement twice, and the models would compare evidences of different data.
assert_distinct_streams <- function(streams) {
  envs <- lapply(streams, function(s) s$state)
  for (i in seq_along(envs)[-1L]) {
    same <- which(vapply(envs[seq_len(i - 1L)], identical, logical(1), envs[[i]]))
    if (length(same) > 0L) {
      griddy_abort("Models `", names(streams)[same[1]], "` and `", names(streams)[i],
                   "` are the same stream: it would take every measurement twice. Give ",
                   "each model a griddy_stream() of its own.", class = "duplicate_stream")
    }
  }
  invisible(streams)
}

# A stream updated outside this model choice (directly, or by another
# stream_models() that holds it too) no longer holds the models' data: its
# evidence would be compared with the others' on different data.
assert_streams_in_step <- function(state) {
  n <- vapply(state$streams, nobs, integer(1))
  off <- n != state$n_taken
  if (any(off)) {
    griddy_abort("Stream(s) ", show_some(paste0("`", names(n)[off], "`")), " hold ",
                 show_some(n[off]), " measurement(s) where the models have taken ",
                 state$n_taken, ": they were updated outside this stream_models() (directly ",
                 "or by another one holding them), so the evidences would compare different ",
                 "data. Give each stream_models() streams of its own, updated only through it.",
                 class = "stream_changed")
  }
  invisible(state)
}

# The models' state and every stream's, to put back when an update fails
# part-way: an update reaches every model or none. The forms C are changed
# in place by stream_add_cpp(), so they are copied; everything else is
# replaced, not changed, by an update, and a reference to it is enough.
models_snapshot <- function(state) {
  list(models = as.list(state, all.names = TRUE),
       streams = lapply(state$streams, function(s) {
         saved <- as.list(s$state, all.names = TRUE)
         saved$C <- rlang::duplicate(saved$C, shallow = FALSE)
         saved
       }))
}

models_restore <- function(state, saved) {
  restore_env(state, saved$models)
  for (m in seq_along(saved$streams)) restore_env(state$streams[[m]]$state, saved$streams[[m]])
  invisible(state)
}

restore_env <- function(env, values) {
  rm(list = setdiff(ls(env, all.names = TRUE), names(values)), envir = env)
  list2env(values, envir = env)
}

# One measurement: every stream updated, the one-step predictive densities
# from the evidences, the flattened probabilities times them.
models_add <- function(state, y, x, t) {
  before <- state$log_evidence
  for (s in state$streams) update(s, y = y, x = x, t = t)
  state$n_taken <- state$n_taken + 1L
  state$log_evidence <- vapply(state$streams, function(s) as.numeric(logLik(s)), numeric(1))
  log_pred <- state$log_evidence - before
  state$log_prob <- normalise_log_prob(normalise_log_prob(state$forgetting * state$log_prob) +
                                         log_pred)
  state$history[[length(state$history) + 1L]] <-
    list(x = x, t = t, y = y, prob = exp(state$log_prob), log_pred = log_pred)
  invisible(state)
}

#' History and evidence of a model choice
#'
#' @param x,object A [stream_models()].
#' @param row.names,optional,... Ignored.
#' @return `as.data.frame()`: one row per measurement taken (`step`, the x
#'   columns when the libraries have several settings, `t`, `y`), with the
#'   probability of each model after it (`prob_<model>`) and the log
#'   one-step predictive density of each (`log_pred_<model>`); `logLik()`:
#'   each model's log evidence so far (a named vector); `print()`: `x`,
#'   invisibly.
#' @name stream_models-methods
#' @examples
#' ex <- griddy_example()
#' rival <- sim_library(ex$library$theta, 0.9 * ex$library$y, x = ex$library$x,
#'                      t = ex$library$t)
#' m <- stream_models(spring = griddy_stream(ex$library), damped = griddy_stream(rival))
#' update(m, y = ex$field)
#' logLik(m)
#' head(as.data.frame(m))
NULL

#' @rdname stream_models-methods
#' @export
as.data.frame.griddy_stream_models <- function(x, row.names = NULL, optional = FALSE, ...) {
  h <- x$state$history
  models <- names(x$state$streams)
  if (length(h) == 0L) return(data.frame())
  prob <- do.call(rbind, lapply(h, `[[`, "prob"))
  pred <- do.call(rbind, lapply(h, `[[`, "log_pred"))
  colnames(prob) <- paste0("prob_", models)
  colnames(pred) <- paste0("log_pred_", models)
  settings <- do.call(rbind, lapply(h, `[[`, "x"))
  out <- data.frame(step = seq_along(h), t = vapply(h, `[[`, 0, "t"),
                    y = vapply(h, `[[`, 0, "y"))
  if (!is.null(settings)) out <- cbind(out["step"], settings, out[c("t", "y")])
  rownames(out) <- NULL
  cbind(out, prob, pred)
}

#' @rdname stream_models-methods
#' @export
logLik.griddy_stream_models <- function(object, ...) object$state$log_evidence

#' @rdname stream_models-methods
#' @export
print.griddy_stream_models <- function(x, ...) {
  state <- x$state
  cli::cat_line("<griddy_stream_models> ", length(state$streams), " models, ",
                nobs(state$streams[[1]]), " measurement(s); forgetting ",
                format(state$forgetting))
  tab <- data.frame(model = names(state$streams), probability = exp(state$log_prob),
                    log_evidence = state$log_evidence)
  print(format(tab, digits = 4), row.names = FALSE)
  invisible(x)
}

# `$streams` reads the streams.
#' @export
`$.griddy_stream_models` <- function(x, name) {
  if (identical(name, "streams")) return(.subset2(x, "state")$streams)
  .subset2(x, name)
}
