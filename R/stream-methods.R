# What a stream answers at any moment, from its accumulated statistics: the
# exact posterior (through the same engine as posterior_exact()), the log
# evidence, summaries and draws. Each answer is computed when asked (one or
# two passes over the runs) and kept until the next update.

# The calibration problem of the data so far, as calibration_problem() would
# build it: the effective form of the noise groups (fold_groups()), the
# group sizes, the log-determinants and the priors.
stream_problem <- function(state) {
  G <- length(state$rho_t)
  K <- length(state$labels)
  setup <- list(group_sizes = state$n, logdet = state$logdet, fold_prior = state$prior)
  C <- state$C
  if (K > 1L) {
    C <- vapply(seq_len(G), function(g) fold_groups(state$C[, g + G * (seq_len(K) - 1L)],
                                                    setup), numeric(nrow(C)))
    C <- matrix(C, ncol = G)
  }
  list(C = C, prior = state$prior, setup = setup, log_prior_run = state$log_prior_run,
       log_prior_grid = state$log_prior_grid, grid = state$grid)
}

# The log evidence of the data so far: the log mass of the exact posterior
# (log_mass_cpp(), the pruned sum that grid_posterior() uses too, in
# src/grid_posterior.h) plus its constant; NA for an improper prior (as
# posterior_exact()).
stream_log_evidence <- function(state) {
  if (!is.null(state$cache$log_evidence)) return(state$cache$log_evidence)
  value <- if (state$prior$rate > 0) {
    problem <- stream_problem(state)
    log_mass_cpp(problem$C, state$prior$shape + sum(state$n) / 2, state$prior$rate,
                 state$logdet, state$log_prior_run, state$log_prior_grid, griddy_threads()) +
      log_evidence_constant(state$prior, state$n)
  } else {
    NA_real_
  }
  state$cache$log_evidence <- value
  value
}

# The exact posterior of a stream's data so far (posterior_exact.griddy_stream()).
stream_posterior <- function(stream, joint = TRUE) {
  joint <- assert_flag(joint, "joint")
  state <- stream$state
  if (sum(state$n) == 0L) {
    griddy_abort("The stream has no measurement yet: its posterior is the prior.",
                 class = "input")
  }
  exact_from_problem(stream_problem(state), joint)
}

# The exact margins, kept until the next update, and the resolution table
# of the runs' posterior (resolution.R).
stream_margins <- function(stream) {
  state <- stream$state
  if (is.null(state$cache$margins)) {
    margins <- stream_posterior(stream, joint = FALSE)
    margins$resolution <- resolution_table(margins$run, lib_theta(state$library))
    state$cache$margins <- margins
    state$cache$log_evidence <- margins$log_evidence
  }
  state$cache$margins
}

# calibrate()'s resolution warning, from the stream's exact posterior.
stream_warn_resolution <- function(stream) {
  warn_resolution(list(resolution = stream_margins(stream)$resolution))
}

#' Methods for a streaming calibration
#'
#' What a [griddy_stream()] answers after any number of updates, all from
#' the exact posterior of the data so far (no sampling): `logLik()` the log
#' evidence (the running sum of the log one-step predictive densities, equal
#' to that of [posterior_exact()] on all the data); `nobs()` the number of
#' measurements; `summary()` one row per \eqn{\theta} parameter (and per
#' correlation parameter) with the exact posterior mean, the central
#' interval over library values, and the resolution check of
#' [summary.griddy_fit()]; `coef()` the posterior means; `confint()` the
#' intervals; `print()` a short account. `summary()`, `coef()` and
#' `confint()` give [calibrate()]'s warning (class
#' `griddy_warning_resolution`) when the posterior has collapsed onto fewer
#' effective library values than resolve it: then [refine()] adds runs
#' where the posterior is (it takes a fit: `refine(calibrate(library,
#' field_data(stream_data(s)), ...))`, with a simulator; a new stream over
#' the refined library then takes the data so far and goes on).
#'
#' @param object,x A [griddy_stream()].
#' @param level Probability of the central interval.
#' @param parm Parameters (names or indices); all by default.
#' @param ... Ignored.
#' @return `logLik()`: a `logLik` object (`NA` for an improper prior);
#'   `nobs()`: an integer; `summary()`: a data.frame of class
#'   `griddy_stream_summary` with columns `parameter`, `mean`, `lower`,
#'   `upper`, `effective_values` and `resolution`, and attributes `level`,
#'   `effective_runs` and `log_evidence`; `coef()`: a named vector;
#'   `confint()`: a matrix with one row per parameter; `print()`: its
#'   argument, invisibly.
#' @name griddy_stream-methods
#' @examples
#' ex <- griddy_example()
#' s <- update(griddy_stream(ex$library, rho_t = c(0, 0.5)), y = ex$field)
#' logLik(s)
#' summary(s)
#' coef(s)
#' confint(s)
NULL

#' @rdname griddy_stream-methods
#' @export
logLik.griddy_stream <- function(object, ...) {
  state <- object$state
  structure(stream_log_evidence(state),
            df = ncol(lib_theta(state$library)) + ncol(state$grid) + length(state$labels),
            nobs = sum(state$n), class = "logLik")
}

#' @rdname griddy_stream-methods
#' @export
nobs.griddy_stream <- function(object, ...) as.integer(sum(object$state$n))

#' @rdname griddy_stream-methods
#' @export
summary.griddy_stream <- function(object, level = 0.95, ...) {
  assert_level(level)
  margins <- stream_margins(object)
  stream_warn_resolution(object)
  theta <- lib_theta(object$state$library)
  tab <- if (level == 0.95) margins$resolution else resolution_table(margins$run, theta, level)
  rows <- data.frame(parameter = tab$parameter,
                     mean = vapply(theta, function(v) sum(margins$run * v), numeric(1)),
                     lower = tab$lower, upper = tab$upper,
                     effective_values = tab$effective_values,
                     resolution = ifelse(tab$limited, "limited", "resolved"))
  grid <- margins$grid
  for (p in setdiff(names(grid), "prob")) {
    bounds <- weighted_quantile(grid[[p]], grid$prob, c((1 - level) / 2, (1 + level) / 2))
    rows <- rbind(rows, data.frame(parameter = p, mean = sum(grid$prob * grid[[p]]),
                                   lower = bounds[1], upper = bounds[2],
                                   effective_values = effective_count(tapply(grid$prob, grid[[p]], sum)),
                                   resolution = NA_character_))
  }
  rownames(rows) <- NULL
  structure(rows, class = c("griddy_stream_summary", "data.frame"), level = level,
            effective_runs = effective_count(margins$run), log_evidence = margins$log_evidence,
            n_obs = nobs(object))
}

#' @export
print.griddy_stream_summary <- function(x, digits = 4, ...) {
  cli::cat_line("Streaming calibration: ", attr(x, "n_obs"), " measurement(s); exact ",
                "posterior, ", format(100 * attr(x, "level")), "% intervals over library ",
                "values")
  print(format(as.data.frame(unclass(x)), digits = digits), row.names = FALSE)
  cli::cat_line("Effective number of runs ", format(attr(x, "effective_runs"), digits = 3),
                "; log evidence ", format(attr(x, "log_evidence"), digits = 6), ".")
  invisible(x)
}

#' @rdname griddy_stream-methods
#' @export
coef.griddy_stream <- function(object, ...) {
  s <- summary(object)
  stats::setNames(s$mean, s$parameter)
}

#' @rdname griddy_stream-methods
#' @export
confint.griddy_stream <- function(object, parm, level = 0.95, ...) {
  s <- summary(object, level = level)
  out <- cbind(s$lower, s$upper)
  dimnames(out) <- list(s$parameter, format_percent(c((1 - level) / 2, (1 + level) / 2)))
  if (!missing(parm)) out <- out[select_parameters(rownames(out), parm), , drop = FALSE]
  out
}

#' @rdname griddy_stream-methods
#' @export
print.griddy_stream <- function(x, ...) {
  state <- x$state
  cli::cat_line("<griddy_stream> ", format_count(nrow(state$outputs)), " runs x ",
                length(state$rho_t), " correlation grid point(s)",
                if (length(state$labels) > 1L) paste0(" x ", length(state$labels),
                                                      " noise groups"))
  n <- nobs(x)
  cli::cat_line("  measurements so far: ", n)
  if (n > 0L) {
    margins <- stream_margins(x)
    top <- order(margins$run, decreasing = TRUE)[seq_len(min(5L, length(margins$run)))]
    cli::cat_line("  effective number of runs: ", format(effective_count(margins$run), digits = 3))
    cli::cat_line("  most probable runs: ", paste0(top, " (", format(margins$run[top],
                                                                     digits = 3), ")",
                                                   collapse = ", "))
    cli::cat_line("  log evidence: ", format(margins$log_evidence, digits = 6))
  }
  invisible(x)
}

#' Exact draws from a stream's posterior
#'
#' Independent draws of (run, correlation grid point) from the exact joint
#' posterior of the data so far, with each noise group's precision
#' \eqn{\tau_k} drawn from its conditional Gamma(a + n_k/2, b + C_k/2).
#' No Markov chain: every draw is independent.
#'
#' @param stream A [griddy_stream()] with at least one measurement.
#' @param n Number of draws.
#' @param seed `NULL` or an integer seed (R's generator; `set.seed()` works
#'   too).
#' @return A data.frame with one row per draw: `run` (the library row), the
#'   \eqn{\theta} columns, the correlation parameters of the grid, and `tau`
#'   (or `tau_<label>` for each noise group).
#' @examples
#' ex <- griddy_example()
#' s <- update(griddy_stream(ex$library), y = ex$field)
#' head(stream_draws(s, 100, seed = 1))
#' @export
stream_draws <- function(stream, n = 1000, seed = NULL) {
  assert_stream(stream)
  n <- assert_whole(n, "n", lower = 1)
  seed <- assert_seed(seed)
  state <- stream$state
  exact <- stream_posterior(stream, joint = TRUE)
  N <- nrow(state$C)
  G <- length(state$rho_t)
  K <- length(state$labels)
  with_seed(seed, {
    cell <- sample.int(N * G, n, replace = TRUE, prob = exact$joint)
    run <- (cell - 1L) %% N + 1L
    g <- (cell - 1L) %/% N + 1L
    tau <- vapply(seq_len(K), function(k) {
      stats::rgamma(n, state$prior$shape + state$n[k] / 2,
                    state$prior$rate + state$C[cbind(run, g + G * (k - 1L))] / 2)
    }, numeric(n))
  })
  tau <- as.data.frame(matrix(tau, n, K))
  names(tau) <- if (K == 1L) "tau" else paste0("tau_", state$labels)
  out <- cbind(data.frame(run = run), lib_theta(state$library)[run, , drop = FALSE],
               state$grid[g, , drop = FALSE], tau)
  rownames(out) <- NULL
  out
}
