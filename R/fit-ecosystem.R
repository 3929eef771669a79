#' Draws of a griddy fit for the posterior and bayesplot packages
#'
#' Converts the kept draws of a [calibrate()] or [refine()] fit into one of
#' the [posterior][posterior::draws] package's formats, so that
#' [posterior::summarise_draws()], [posterior::rhat()], the bayesplot
#' `mcmc_*()` plots and other tools that take draws can be used. The
#' posterior package is one of griddy's imports, so it is installed with
#' griddy, and these methods are registered as soon as it is loaded (calling
#' `posterior::as_draws_df()` loads it); the bayesplot package is suggested,
#' needed only for its plots.
#'
#' There is one variable per sampled parameter, as in
#' [summary()][summary.griddy_fit] and [coda::as.mcmc.list()]: each
#' \eqn{\theta} column, `tau` (or one `tau_<label>` per noise group) and each
#' correlation parameter whose grid has more than one value. The values are
#' those of [as.data.frame()][as.data.frame.griddy_fit]; `.chain` is the
#' chain and `.iteration` numbers the kept draws of each chain from 1 (the
#' sampler's own iteration is the `iteration` column of
#' [as.data.frame()][as.data.frame.griddy_fit]).
#' `posterior::as_draws_array()`, `as_draws_list()`, `as_draws_matrix()` and
#' `as_draws_rvars()` work on a fit through these methods.
#'
#' @param x A `griddy_fit` from [calibrate()] or [refine()].
#' @param ... Passed to [posterior::as_draws_df()].
#' @return A [posterior::draws_df] with one column per sampled parameter and
#'   the columns `.chain`, `.iteration` and `.draw`.
#' @examples
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 600, burn_in = 100,
#'                  chains = 2, seed = 1)
#' d <- posterior::as_draws_df(fit)
#' d
#' posterior::summarise_draws(fit)
#' @name griddy_fit-draws
NULL

#' @rdname griddy_fit-draws
#' @usage \method{as_draws_df}{griddy_fit}(x, ...)
#' @exportS3Method posterior::as_draws_df
as_draws_df.griddy_fit <- function(x, ...) {
  require_package("posterior", "to convert draws to the posterior package's formats")
  draws <- parameter_draws(x)
  chain <- x$draws$chain
  ord <- order(chain, x$draws$iteration)
  draws <- draws[ord, , drop = FALSE]
  chain <- chain[ord]
  draws$.chain <- as.integer(factor(chain))
  draws$.iteration <- stats::ave(seq_along(chain), chain, FUN = seq_along)
  rownames(draws) <- NULL
  posterior::as_draws_df(draws, ...)
}

#' @rdname griddy_fit-draws
#' @usage \method{as_draws}{griddy_fit}(x, ...)
#' @exportS3Method posterior::as_draws
as_draws.griddy_fit <- function(x, ...) as_draws_df.griddy_fit(x, ...)

#' Estimates, intervals, likelihood and tidy summaries of a griddy fit
#'
#' The methods R users expect of a fitted model. Point estimates and
#' intervals are those of [summary()][summary.griddy_fit], over the same
#' sampled parameters (each \eqn{\theta} column, `tau` or each
#' `tau_<label>`, and each correlation parameter whose grid has more than one
#' value):
#'
#' * `coef()`: by default the same point estimate as `summary()`'s
#'   `estimate` column, so `coef()`, `tidy()` and `summary()` report one
#'   number per parameter: the posterior mean where it lies within the 95%
#'   interval, otherwise the median (`summary()` marks that case with `*`).
#'   `point = "median"` or `point = "mean"` give the median or mean of every
#'   parameter. The \eqn{\theta} posterior is discrete, over the library's
#'   values: its median is a library value and always lies within the central
#'   interval, while the mean may fall between runs and, for a posterior on
#'   one value with a few draws far off, even outside the interval.
#' * `confint()`: central (equal-tailed) posterior intervals, the type-1
#'   quantiles of the draws as in `summary()`, so \eqn{\theta} bounds are
#'   library values.
#' * `logLik()`: the log **marginal** likelihood (log evidence) of the data
#'   under the stated priors, computed exactly over the library and the
#'   correlation grid (see [posterior_exact()]); every parameter is
#'   integrated out, so differences between fits on the same data are log
#'   Bayes factors. Its `df` is the number of sampled parameters (as in
#'   `coef()`), and `nobs` the number of measurements; information criteria
#'   such as [AIC()] built from it are not meaningful for this likelihood.
#'   With an improper prior (`prior$rate` = 0) the evidence does not exist
#'   and `logLik()` is an error of class `griddy_error_improper_prior`.
#' * `nobs()`: the number of measurements used in the likelihood (observed
#'   field points, replicates included; missing cells are not counted).
#' * `tidy()` ([generics::tidy()], as in broom): one row per parameter.
#' * `glance()` ([generics::glance()]): one row describing the fit.
#'
#' @param object,x A `griddy_fit` from [calibrate()] or [refine()].
#' @param point `"estimate"` (the default): `summary()`'s `estimate`, the
#'   mean where it lies within the central interval (of probability 0.95 for
#'   `coef()`, `conf.level` for `tidy()`), otherwise the median; or
#'   `"median"` or `"mean"` of the draws.
#' @param parm Parameters: names or positions among `names(coef(object))`;
#'   all by default.
#' @param level,conf.level Probability of the central interval.
#' @param conf.int Whether `tidy()` adds the interval columns.
#' @param ... Ignored.
#' @return `coef()`: a named numeric vector. `confint()`: a matrix with one
#'   row per parameter and two columns named by their probabilities
#'   (`"2.5 %"`, `"97.5 %"`), as [stats::confint()]. `logLik()`: an object of
#'   class `logLik` with attributes `df` and `nobs`. `nobs()`: an integer.
#'   `tidy()`: a data.frame with columns `term`, `estimate` (as `coef()`),
#'   `std.error` (the posterior standard deviation) and, with `conf.int`,
#'   `conf.low` and `conf.high`. `glance()`: a one-row data.frame with
#'   `n_obs`, `n_missing` (missing field cells), `n_runs` (library runs),
#'   `n_grid` (correlation grid points), `chains`, `draws` (kept draws over
#'   all chains), `log_evidence` (`NA` with an improper prior),
#'   `effective_runs` (\eqn{1 / \sum p_i^2} over the exact posterior of the
#'   runs), `effective_runs_sampled` (the same over the sampled frequencies)
#'   and `runtime` (seconds: the whole [calibrate()] call, see its `runtime`).
#' @examples
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 600, burn_in = 100,
#'                  chains = 2, seed = 1)
#' coef(fit)
#' confint(fit, level = 0.9)
#' logLik(fit)
#' nobs(fit)
#' tidy(fit)
#' glance(fit)
#' @name griddy_fit-methods
NULL

#' @rdname griddy_fit-methods
#' @importFrom stats coef confint logLik nobs
#' @export
coef.griddy_fit <- function(object, point = c("estimate", "median", "mean"), ...) {
  point <- assert_choice(point, "point", point_choices, vector_default = TRUE)
  point_estimates(parameter_draws(object), point, level = 0.95, type = 1)
}

point_choices <- c("estimate", "median", "mean")

# One point estimate per column of draws, as summary() computes it.
point_estimates <- function(draws, point, level, type) {
  vapply(draws, function(v) draws_estimates(v, level, type)[[point]], numeric(1))
}

#' @rdname griddy_fit-methods
#' @export
confint.griddy_fit <- function(object, parm, level = 0.95, ...) {
  draws_confint(parameter_draws(object), parm, level, type = 1)
}

# Central intervals of the columns of a data.frame of draws, as
# stats::confint() lays them out.
draws_confint <- function(draws, parm, level, type) {
  assert_level(level)
  if (!missing(parm)) draws <- draws[select_parameters(names(draws), parm)]
  tail <- (1 - level) / 2
  probs <- c(tail, 1 - tail)
  out <- t(vapply(draws, stats::quantile, numeric(2), probs = probs, type = type,
                  names = FALSE))
  dimnames(out) <- list(names(draws), format_percent(probs))
  out
}

# stats:::format.perc()'s column names: "2.5 %", "97.5 %".
format_percent <- function(probs) {
  paste(format(100 * probs, trim = TRUE, scientific = FALSE, digits = 3), "%")
}

select_parameters <- function(names, parm) {
  if (is.numeric(parm)) {
    bad <- is.na(parm) | parm < 1 | parm > length(names) | parm != round(parm)
    if (any(bad)) {
      griddy_abort("`parm` positions must be between 1 and ", length(names), ".",
                   class = "input")
    }
    return(names[parm])
  }
  if (!is.character(parm) || anyNA(parm)) {
    griddy_abort("`parm` must be parameter names or positions.", class = "input")
  }
  unknown <- setdiff(parm, names)
  if (length(unknown) > 0L) {
    griddy_abort("Unknown parameter(s) in `parm`: ", paste(unknown, collapse = ", "),
                 ". The parameters are: ", paste(names, collapse = ", "), ".",
                 class = "input")
  }
  parm
}

#' @rdname griddy_fit-methods
#' @export
logLik.griddy_fit <- function(object, ...) {
  if (object$prior$rate == 0) {
    griddy_abort("The log marginal likelihood does not exist: the Gamma prior on tau is ",
                 "improper (`prior$rate` = 0). Fit with a positive rate to compare models.",
                 class = "improper_prior")
  }
  structure(exact_margins(object)$log_evidence,
            df = ncol(parameter_draws(object)), nobs = nobs(object),
            class = "logLik")
}

#' @rdname griddy_fit-methods
#' @export
nobs.griddy_fit <- function(object, ...) as.integer(object$n_obs)

#' @rdname griddy_fit-methods
#' @importFrom generics tidy
#' @method tidy griddy_fit
#' @export
tidy.griddy_fit <- function(x, conf.int = TRUE, conf.level = 0.95,
                            point = c("estimate", "median", "mean"), ...) {
  point <- assert_choice(point, "point", point_choices, vector_default = TRUE)
  draws_tidy(parameter_draws(x), conf.int, conf.level, point, type = 1)
}

draws_tidy <- function(draws, conf.int, conf.level, point, type) {
  out <- data.frame(term = names(draws),
                    estimate = unname(point_estimates(draws, point, conf.level, type)),
                    std.error = vapply(draws, stats::sd, numeric(1), USE.NAMES = FALSE))
  if (isTRUE(conf.int)) {
    ci <- draws_confint(draws, level = conf.level, type = type)
    out$conf.low <- unname(ci[, 1])
    out$conf.high <- unname(ci[, 2])
  }
  out
}

#' @rdname griddy_fit-methods
#' @importFrom generics glance
#' @method glance griddy_fit
#' @export
glance.griddy_fit <- function(x, ...) {
  exact <- exact_margins(x)
  sampled <- tabulate(x$draws$run, nbins = length(exact$run)) / nrow(x$draws)
  data.frame(n_obs = nobs(x), n_missing = sum(is.na(x$y_field)),
             n_runs = lib_n_runs(x$library), n_grid = nrow(x$grid),
             chains = x$control$chains, draws = nrow(x$draws),
             log_evidence = if (x$prior$rate == 0) NA_real_ else exact$log_evidence,
             effective_runs = effective_count(exact$run),
             effective_runs_sampled = effective_count(sampled),
             runtime = sum(x$runtime))
}

#' @importFrom generics tidy
#' @export
generics::tidy

#' @importFrom generics glance
#' @export
generics::glance

#' Estimates and intervals of a Kennedy-O'Hagan fit
#'
#' `coef()`, `confint()`, `nobs()` and `tidy()` for [koh_calibrate()]'s
#' baseline, over its \eqn{\theta} parameters (not the discrepancy variance
#' `sigma2`), as in [summary()][summary.griddy_koh]. The posterior is
#' continuous, so intervals use R's default (type 7) quantiles. `coef()` and
#' `tidy()` give `summary()`'s `estimate` by default, as for a [calibrate()]
#' fit.
#'
#' @param object,x A `griddy_koh` from [koh_calibrate()].
#' @inheritParams griddy_fit-methods
#' @return `coef()`: a named numeric vector. `confint()`: a matrix with one
#'   row per parameter and two columns named by their probabilities.
#'   `nobs()`: the number of observed field points. `tidy()`: a data.frame
#'   with columns `term`, `estimate`, `std.error` and, with `conf.int`,
#'   `conf.low` and `conf.high`.
#' @examplesIf requireNamespace("RobustCalibration", quietly = TRUE)
#' f <- piston_field_data(15, seed = 1)
#' lib <- piston_library(4, locations = attr(f, "locations"))
#' koh <- koh_calibrate(lib, f, n_iter = 1500, burn_in = 500, tune_iter = 300,
#'                      seed = 1)
#' coef(koh)
#' confint(koh)
#' nobs(koh)
#' @name griddy_koh-methods
NULL

koh_draws <- function(object) object$draws[object$parameters]

#' @rdname griddy_koh-methods
#' @export
coef.griddy_koh <- function(object, point = c("estimate", "median", "mean"), ...) {
  point <- assert_choice(point, "point", point_choices, vector_default = TRUE)
  point_estimates(koh_draws(object), point, level = 0.95, type = 7)
}

#' @rdname griddy_koh-methods
#' @export
confint.griddy_koh <- function(object, parm, level = 0.95, ...) {
  draws_confint(koh_draws(object), parm, level, type = 7)
}

#' @rdname griddy_koh-methods
#' @export
nobs.griddy_koh <- function(object, ...) sum(!is.na(object$y_field))

#' @rdname griddy_koh-methods
#' @method tidy griddy_koh
#' @export
tidy.griddy_koh <- function(x, conf.int = TRUE, conf.level = 0.95,
                            point = c("estimate", "median", "mean"), ...) {
  point <- assert_choice(point, "point", point_choices, vector_default = TRUE)
  draws_tidy(koh_draws(x), conf.int, conf.level, point, type = 7)
}
