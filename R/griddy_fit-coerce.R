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
  d[setdiff(names(d), c("chain", "iteration", "run", fixed))]
}
