#' Summarise a griddy fit
#'
#' One row per sampled parameter (each \eqn{\theta} column, `tau`, each
#' correlation parameter), with the library adequacy checks: the effective
#' number of runs that carry the posterior (\eqn{1 / \sum p_i^2}), the
#' posterior mass on runs at the edge of the library's \eqn{\theta} range,
#' the distance between the sampled and the exact posterior over runs, and a
#' warning when the posterior sits on one run (its interval then shows the
#' library's resolution, not the data's uncertainty).
#'
#' Bounds are quantiles of the draws (type 1, so for \eqn{\theta} they are
#' library values). `ess` is [coda::effectiveSize()] summed over chains;
#' `rhat` is [coda::gelman.diag()]'s point estimate, `NA` with one chain or a
#' constant parameter.
#'
#' @param object,x A `griddy_fit` from [calibrate()], or its summary.
#' @param level Probability of the central interval.
#' @param digits Significant digits to print.
#' @param ... Ignored.
#' @return `summary()`: a data.frame of class `griddy_summary` with columns
#'   `parameter`, `mean`, `median`, `lower`, `upper`, `ess` and `rhat`, and
#'   the adequacy checks in attribute `"adequacy"`. `print()` returns its
#'   argument invisibly.
#' @examples
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 1000, burn_in = 200,
#'                  chains = 2, seed = 1)
#' s <- summary(fit)
#' s
#' s[s$parameter == "k", c("lower", "upper")]
#' @export
summary.griddy_fit <- function(object, level = 0.95, ...) {
  assert_level(level)
  draws <- parameter_draws(object)
  chains <- split(draws, object$draws$chain)
  tail <- (1 - level) / 2
  rows <- lapply(names(draws), function(p) {
    v <- draws[[p]]
    q <- stats::quantile(v, c(tail, 0.5, 1 - tail), type = 1, names = FALSE)
    data.frame(parameter = p, mean = mean(v), median = q[2], lower = q[1], upper = q[3],
               ess = effective_size(lapply(chains, `[[`, p)),
               rhat = potential_scale_reduction(lapply(chains, `[[`, p)))
  })
  out <- do.call(rbind, rows)
  structure(out, class = c("griddy_summary", "data.frame"),
            adequacy = library_adequacy(object), level = level,
            info = fit_description(object))
}

effective_size <- function(chains) {
  if (all(vapply(chains, function(v) all(v == v[1]), logical(1)))) {
    return(NA_real_)
  }
  sum(vapply(chains, function(v) {
    if (all(v == v[1])) 0 else unname(coda::effectiveSize(v))
  }, numeric(1)))
}

potential_scale_reduction <- function(chains) {
  if (length(chains) < 2L || all(unlist(chains) == chains[[1]][1])) {
    return(NA_real_)
  }
  mc <- coda::mcmc.list(lapply(chains, coda::mcmc))
  tryCatch(coda::gelman.diag(mc, autoburnin = FALSE)$psrf[1, 1],
           error = function(e) NA_real_)
}

fit_description <- function(fit) {
  ctrl <- fit$control
  paste0("Griddy Gibbs (", fit$update, " update) over ", lib_n_runs(fit$library),
         " runs x ", nrow(fit$grid), " correlation grid point(s); ", length(fit$y_field),
         " data points; ", ctrl$chains, " chain(s) x ", ctrl$n_iter, " iterations (burn-in ",
         ctrl$burn_in, ", thin ", ctrl$thin, "); ",
         format(sum(fit$runtime), digits = 3), " s")
}

#' @rdname summary.griddy_fit
#' @export
print.griddy_summary <- function(x, digits = 4, ...) {
  cli::cat_line(attr(x, "info"))
  level <- if (is.null(attr(x, "level"))) 0.95 else attr(x, "level")
  tab <- as.data.frame(x)
  class(tab) <- "data.frame"
  bounds <- names(tab) %in% c("lower", "upper")
  names(tab)[bounds] <- paste0(names(tab)[bounds], " (", format(100 * level), "%)")
  print(tab, digits = digits, row.names = FALSE)
  if (!is.null(attr(x, "adequacy"))) cli::cat_line(format_adequacy(attr(x, "adequacy")))
  invisible(x)
}

#' @rdname summary.griddy_fit
#' @export
print.griddy_fit <- function(x, digits = 4, ...) {
  print(summary(x), digits = digits)
  invisible(x)
}
