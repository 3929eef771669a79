#' Draws of a griddy fit as a data.frame or a coda object
#'
#' @param x A `griddy_fit` from [calibrate()].
#' @param row.names,optional Ignored; for compatibility with the generic.
#' @param ... Ignored.
#' @return `as.data.frame()`: one row per kept draw, with columns `chain`,
#'   `iteration`, `run` (the library row), the \eqn{\theta} columns, `tau`
#'   (or, with noise groups, `tau_<label>` for each group; see [calibrate()])
#'   and one column per correlation parameter (see [rho_grid()]).
#'   `as.mcmc.list()`: a [coda::mcmc.list()] with one [coda::mcmc()] per chain,
#'   holding the \eqn{\theta} columns, the precision(s) and the correlation parameters
#'   that were sampled (those whose grid has more than one value).
#' @examples
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 600, burn_in = 100,
#'                  chains = 2, seed = 1)
#' head(as.data.frame(fit))
#' coda::effectiveSize(coda::as.mcmc.list(fit))
#' @name griddy_fit-coerce
NULL

#' @rdname griddy_fit-coerce
#' @export
as.data.frame.griddy_fit <- function(x, row.names = NULL, optional = FALSE, ...) {
  d <- x$draws
  cbind(d[c("chain", "iteration", "run")],
        rows_at(lib_theta(x$library), d$run),
        d[tau_columns(x)],
        rows_at(x$grid, d$grid_point))
}

# Rows i of a data.frame, column by column: `df[i, ]` makes unique row names
# for repeated rows, which took most of calibrate()'s time on 40,000 draws.
rows_at <- function(df, i) {
  structure(lapply(df, `[`, i), class = "data.frame", row.names = .set_row_names(length(i)))
}

#' @rdname griddy_fit-coerce
#' @importFrom coda as.mcmc.list
#' @method as.mcmc.list griddy_fit
#' @export
as.mcmc.list.griddy_fit <- function(x, ...) {
  draws <- parameter_draws(x)
  ctrl <- x$control
  coda::mcmc.list(lapply(split(draws, x$draws$chain), function(d) {
    coda::mcmc(as.matrix(d), start = ctrl$burn_in + ctrl$thin, thin = ctrl$thin)
  }))
}

# The names of the precision draws: `tau`, or `tau_<label>` per noise group.
tau_columns <- function(fit) grep("^tau(_|$)", names(fit$draws), value = TRUE)

# The sampled parameters: theta columns, tau, and the correlation parameters
# whose grid has more than one value.
parameter_draws <- function(fit) {
  d <- as.data.frame(fit)
  fixed <- names(fit$grid)[vapply(fit$grid, function(v) length(unique(v)) == 1L, logical(1))]
  # a discrepancy's length scales mean nothing at ratio 0 (NA there): its
  # size is summarised by delta_ratio, its shape by discrepancy_evidence()
  lengths <- c("delta_length_x", "delta_length_t")
  d[setdiff(names(d), c("chain", "iteration", "run", fixed, lengths))]
}

#' @rdname griddy_fit-draws
#' @section bayesplot and a library-valued posterior:
#' Each \eqn{\theta} draw is one of the library's values, so its posterior is
#' discrete: a parameter may take two or three values in 40,000 draws.
#' bayesplot's views assume continuous draws on comparable scales, and some
#' of them say little about such a posterior.
#'
#' Views that suit it:
#' * `bayesplot::mcmc_hist(draws)`: one panel per parameter, each on its own
#'   scale; a \eqn{\theta} parameter shows as bars at its library values.
#'   For bars one library value wide, pass `breaks` at the midpoints between
#'   the library's values, one parameter at a time, or use griddy's own
#'   [`plot(fit, "posterior")`][plot.griddy_fit], which draws exactly that
#'   (and, for a scattered design, a density smoothed for its effective runs).
#' * `bayesplot::mcmc_intervals(draws, pars = ...)`, with `pars` limited to
#'   parameters of one scale: it draws every parameter on one axis, so a
#'   stiffness in the thousands beside a precision below 1 flattens the
#'   latter. The \eqn{\theta} bounds are library values, as in
#'   [summary()][summary.griddy_fit].
#' * `tau` and the correlation parameters are continuous or on a grid of
#'   their own; `mcmc_trace(draws, pars = "tau")` reads as usual.
#'
#' Views that do not:
#' * `mcmc_trace()` of a \eqn{\theta} parameter that jumps between two library
#'   values is a solid block between them; [`plot(fit, "trace")`][plot.griddy_fit]
#'   thins the draws for display, and [summary()][summary.griddy_fit]'s
#'   `rhat` and ESS say whether the chains agree.
#' * The rank plots (`mcmc_rank_hist()`, `mcmc_rank_overlay()`): with most
#'   draws tied on one value their ranks are ties, and the histograms are
#'   unreadable.
#' * `mcmc_areas()` and `mcmc_dens()`: a kernel density over a few library
#'   values invents mass between the runs, and `mcmc_areas()` puts every
#'   parameter on one axis.
#' @examplesIf requireNamespace("posterior", quietly = TRUE) && requireNamespace("bayesplot", quietly = TRUE)
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 600, burn_in = 100,
#'                  chains = 2, seed = 1)
#' draws <- posterior::as_draws_df(fit)
#' # each parameter on its own scale: k and c as bars at their library values
#' bayesplot::mcmc_hist(draws, pars = c("k", "c", "tau"))
#' # bars one library value wide, for k
#' k_values <- sort(unique(ex$library$theta$k))
#' mid <- (k_values[-1] + k_values[-length(k_values)]) / 2
#' bayesplot::mcmc_hist(draws, pars = "k",
#'                      breaks = c(2 * k_values[1] - mid[1], mid,
#'                                 2 * k_values[length(k_values)] - mid[length(mid)]))
#' @name griddy_fit-draws
NULL
