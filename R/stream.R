#' A calibration that is updated as measurements arrive
#'
#' `griddy_stream()` starts a calibration over a library with no data (the
#' prior); [update()][update.griddy_stream] adds measurements one at a time
#' or in batches, each in one pass over the runs. At any moment the stream
#' answers with the exact posterior ([posterior_exact()] of the stream is
#' the same object as `posterior_exact(library, all data so far)`), the log
#' evidence ([logLik()][logLik.griddy_stream]), [summary()][summary.griddy_stream],
#' [coef()][coef.griddy_stream], [confint()][confint.griddy_stream] and
#' exact draws ([stream_draws()]).
#'
#' **Why it is exact and cheap.** With \eqn{\tau} integrated out under its
#' Gamma(a, b) prior, the posterior over (run \eqn{i}, grid point \eqn{g})
#' depends on the data only through each run's quadratic form
#' \eqn{C_{ig}} (one per noise group), the data size \eqn{n} and
#' \eqn{\log|R_g|} (see [posterior_exact()]). A new measurement \eqn{y} at
#' x setting \eqn{k} and output coordinate \eqn{t_j} adds one term to every
#' \eqn{C_{ig}}:
#' * independent noise (\eqn{\rho_t = 0}): \eqn{(y - g_i(k, j))^2};
#' * AR(1) over t (\eqn{\rho_t > 0}), when the measurements at a setting
#'   arrive in increasing t: the innovation \eqn{e_j - \phi e_{j'}}, with
#'   \eqn{e} the residuals, \eqn{j'} the previous measurement at that
#'   setting (and noise group) and \eqn{\phi = \rho_t^{s_j - s_{j'}}} on t
#'   scaled to \[0, 1] as [rho_grid()] defines it, adds
#'   \eqn{(e_j - \phi e_{j'})^2 / (1 - \phi^2)}, and \eqn{\log|R_g|} grows
#'   by \eqn{\log(1 - \phi^2)} (the prediction-error decomposition of the
#'   AR(1) likelihood: the sum over the measurements equals the batch
#'   quadratic form and log-determinant exactly).
#'
#' **What is not incremental.** A correlation across x settings
#' (`rho_x` other than 0 with several settings) couples every setting's
#' residuals: `griddy_stream()` refuses it (an error of class
#' `griddy_error_unsupported`); use [calibrate()] or [posterior_exact()].
#' Under AR(1), a measurement at an earlier t than the last one at its
#' setting and group breaks the innovations order: the stream then
#' recomputes its forms from all the data so far, in t order (a message of
#' class `griddy_message_stream_replay`; one pass over the runs per
#' measurement so far), and a second measurement of the same (x, t) is
#' refused (class `griddy_error_unsupported`). Independent noise takes any
#' order and replicates (their sum of squares is what [calibrate()] uses).
#' Relative `sd` of measurements (see [field_data()]) are not taken, nor
#' runs predicted by an emulator ([emulated_library()], or [refine()]
#' without a simulator), whose likelihood holds the emulator's error.
#'
#' **A stream is a reference object.** Its state (the N x G forms per
#' noise group) is changed in place by `update()`, which returns the same
#' stream, so that an update costs one pass over the runs and no copy:
#' `s2 <- update(s1, ...)` updates `s1` too. The stream keeps the library's
#' outputs in memory (an on-disk library is read once), and the data so
#' far ([stream_data()]).
#'
#' @inheritParams calibrate
#' @param library A library ([sim_library()] or any other griddy library);
#'   its outputs are read into memory once.
#' @param rho_x Correlation over the x settings: 0 (the only value a stream
#'   takes when the library has several settings; see above).
#' @param rho_t Grid of AR(1) correlations over the output coordinate t, as
#'   in [calibrate()].
#' @param prior The Gamma prior on \eqn{\tau}, as in [calibrate()] (`NULL`:
#'   the thesis's vague prior). Its rate must be positive for the evidence
#'   to exist.
#' @param noise_groups As in [calibrate()]: `NULL`, `"x"`, or labels (one
#'   per output coordinate or per library output); each group has its own
#'   \eqn{\tau}.
#' @return A `griddy_stream`: an environment-backed object. Its fields are
#'   internal; use the methods above and [stream_data()].
#' @seealso [update.griddy_stream()], [stream_models()], [posterior_exact()]
#' @references Dawid, A. P. (1984). Statistical theory: the prequential
#'   approach. *Journal of the Royal Statistical Society A* 147(2), 278-292.
#' @examples
#' ex <- griddy_example()
#' s <- griddy_stream(ex$library, rho_t = c(0, 0.5))
#' y <- ex$field$y
#' # measurements one at a time: setting by setting, in time order
#' for (k in seq_len(nrow(y))) {
#'   for (j in seq_len(ncol(y))) {
#'     s <- update(s, y = y[k, j], x = ex$field$x[k, , drop = FALSE], t = ex$library$t[j])
#'   }
#' }
#' s
#' logLik(s)
#' all.equal(posterior_exact(s), posterior_exact(ex$library, ex$field, rho_t = c(0, 0.5)))
#' @export
griddy_stream <- function(library, rho_x = 0, rho_t = 0, prior = NULL, run_weights = NULL,
                          noise_groups = NULL) {
  check_library(library)
  if (any(lib_predicted(library))) {
    griddy_abort("A stream takes simulated runs only: the library's runs predicted by an ",
                 "emulator carry the emulator's error in their likelihood, which the ",
                 "stream's one-term update leaves out. Use calibrate() or posterior_exact().",
                 class = "unsupported")
  }
  grids <- rho_grids(library, rho_x, rho_t)
  if (lib_n_x(library) > 1L && any(unlist(grids$x) != 0)) {
    griddy_abort("A stream takes `rho_x` = 0 only: a correlation across x settings couples ",
                 "every setting's residuals, so a new measurement changes every term of ",
                 "the quadratic form and no update is one pass over the runs. Use ",
                 "calibrate() or posterior_exact() for `rho_x` > 0.", class = "unsupported")
  }
  prior <- assert_prior(if (is.null(prior)) thesis_prior() else prior)
  groups <- noise_group_index(noise_groups, lib_n_x(library), lib_n_t(library))
  n_combos <- prod(lengths(grids$x))
  # the grid prior of calibrate(): every x combination is the identity R_x
  # here, so each rho_t value is one correlation structure
  setup <- list(x_class = rep(1L, n_combos), gx = rep(seq_len(n_combos), length(grids$t)),
                gt = rep(seq_along(grids$t), each = n_combos))
  outputs <- lib_outputs(library)
  storage.mode(outputs) <- "double"
  state <- new.env(parent = emptyenv())
  state$library <- library
  state$outputs <- outputs
  # each output's largest |value|, for the bound on a new term (stream_accumulate())
  state$out_absmax <- apply(abs(outputs), 2, max)
  state$prior <- prior
  state$grid <- grid_table(library, grids)
  state$rho_t <- grids$t[setup$gt]
  state$log_prior_grid <- grid_log_prior(setup)
  state$log_prior_run <- log_run_weights(run_weights, library)
  state$group <- groups$group
  state$labels <- groups$labels
  state$s_unit <- scale_unit(lib_t(library))
  state$markov <- any(state$rho_t != 0)
  stream_reset(state)
  structure(list(state = state), class = "griddy_stream")
}

# Empty the stream's statistics and data: the prior.
stream_reset <- function(state) {
  G <- length(state$rho_t)
  K <- length(state$labels)
  N <- nrow(state$outputs)
  inform_memory(state$library, G * K)
  state$C <- matrix(0, N, G * K)
  state$pending <- list()  # terms not yet in C (stream_flush())
  state$n <- integer(K)
  state$logdet <- numeric(G)
  state$C_bound <- 0  # no form exceeds it: the sum of the terms' bounds
  # per (x setting, noise group): the output column and value of the last
  # measurement, for the AR(1) innovations
  state$last_column <- matrix(NA_integer_, lib_n_x(state$library), K)
  state$last_y <- matrix(NA_real_, lib_n_x(state$library), K)
  state$data <- list(column = integer(), y = numeric())
  state$measured <- logical(ncol(state$outputs))
  state$cache <- NULL
  invisible(state)
}

#' The measurements a stream has taken
#'
#' @param stream A [griddy_stream()].
#' @return A data.frame in the long format of [field_data()], one row per
#'   measurement in arrival order: the library's x columns (none when it
#'   has a single setting), `t` and `y`. `field_data(stream_data(s))` gives
#'   [posterior_exact()] and [calibrate()] the same data as the stream.
#' @examples
#' ex <- griddy_example()
#' s <- update(griddy_stream(ex$library), y = c(0.5, 1.2), x = ex$field$x[c(1, 3), , drop = FALSE],
#'             t = ex$library$t[c(2, 5)])
#' stream_data(s)
#' @export
stream_data <- function(stream) {
  assert_stream(stream)
  state <- stream$state
  column <- state$data$column
  n_t <- lib_n_t(state$library)
  setting <- (column - 1L) %/% n_t + 1L
  x <- lib_x(state$library)
  out <- data.frame(t = lib_t(state$library)[(column - 1L) %% n_t + 1L], y = state$data$y)
  if (lib_n_x(state$library) > 1L || (!is.null(x) && nrow(out) > 0L)) {
    out <- cbind(x[setting, , drop = FALSE], out)
  }
  rownames(out) <- NULL
  out
}

assert_stream <- function(stream, arg = "stream") {
  if (!inherits(stream, "griddy_stream")) {
    griddy_abort("`", arg, "` must be a griddy_stream (see ?griddy_stream); received ",
                 class(stream)[1], ".")
  }
  invisible(stream)
}
