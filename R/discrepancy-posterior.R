# Where the gap lies: the posterior of the discrepancy delta at every library
# output (observed or not), from a fit with a gp_discrepancy(): the mixture
# of delta's conditional law given (run, grid point, tau) (delta_law(),
# discrepancy-law.R) over the fit's kept draws.

#' The posterior of the model discrepancy
#'
#' Where the simulator misses the data: the posterior of the discrepancy
#' \eqn{\delta(x, t)} of a fit made with `discrepancy = gp_discrepancy()`,
#' at every library output (the library's order, measured or not). Given a
#' run, a grid point and \eqn{\tau}, \eqn{\delta} is Gaussian: its mean is
#' the Gaussian-process smooth of the run's residuals \eqn{y - g_i}
#' (\eqn{\lambda K_{\cdot o} \Sigma^{-1} r_i}{lambda K[, o] Sigma^-1 r_i},
#' \eqn{\Sigma = S R_g S + \lambda K}{Sigma = S R_g S + lambda K} over the
#' measured cells \eqn{o}) and its covariance \eqn{\tau^{-1} (\lambda K -
#' \lambda K_{\cdot o} \Sigma^{-1} \lambda K_{o \cdot})}{tau^-1 (lambda K -
#' lambda K[, o] Sigma^-1 lambda K[o, ])}, within
#' each noise group. The posterior is the mixture of these over the fit's
#' kept draws; draws at the ratio \eqn{\lambda = 0} give \eqn{\delta = 0}.
#'
#' The discrepancy is "what the best runs miss", not a unique physical error:
#' an effect that a change of \eqn{\theta} imitates is shared between the two
#' (see [gp_discrepancy()]). At settings the field does not measure,
#' \eqn{\delta} reverts towards its prior mean 0 with its prior spread, as
#' far from the measured settings as its length scales say.
#'
#' @param fit A [calibrate()] fit made with `discrepancy = gp_discrepancy()`.
#' @param level Probability of the pointwise central bands.
#' @param ndraws How many of the kept draws (evenly spaced) to draw
#'   \eqn{\delta} at, for the bands; the mean and sd use every kept draw
#'   (exact mixture moments, no Monte Carlo error beyond the chains').
#' @param seed `NULL`, or a seed for the draws of this call only; either way
#'   [set.seed()] reproduces them.
#' @return A data.frame with one row per library output: `x` (the row of the
#'   library's x settings; named `setting` when an x column is itself named
#'   `x`), the x columns, `t`, `observed` (the field data,
#'   a cell's replicates' mean, `NA` where missing), `residual` (`observed`
#'   minus the posterior mean of the simulator's outputs), and the posterior
#'   of \eqn{\delta}: `mean`, `sd`, `lower`, `upper` (pointwise quantiles of
#'   the draws). Attributes: `draws`, a matrix of the draws of \eqn{\delta}
#'   (one row per draw, one column per library output), `draw_rows` (their
#'   rows of `fit$draws`) and `level`.
#' @seealso [plot.griddy_fit()] (`type = "discrepancy"`),
#'   [predict.griddy_fit()] (`discrepancy = TRUE`), [discrepancy_evidence()].
#' @examples
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 1000, burn_in = 200, seed = 1,
#'                  discrepancy = gp_discrepancy(length_x = 1, length_t = c(0.3, 1)))
#' head(discrepancy_posterior(fit, ndraws = 200, seed = 1))
#' @export
discrepancy_posterior <- function(fit, level = 0.95, ndraws = 1000, seed = NULL) {
  assert_discrepancy_fit(fit)
  assert_level(level)
  ndraws <- assert_count(ndraws, "ndraws")
  seed <- assert_seed(seed)
  moments <- discrepancy_moments(fit)
  pick <- evenly_spaced_draws(fit, ndraws)
  draws <- with_seed(seed, discrepancy_draws(fit, pick))
  probs <- c((1 - level) / 2, 1 - (1 - level) / 2)
  bands <- apply(draws, 2, stats::quantile, probs = probs, names = FALSE)
  out <- cbind(library_cells(fit$library),
               observed = fit$y_field, residual = fit$y_field - posterior_mean_outputs(fit),
               mean = moments$mean, sd = moments$sd,
               lower = bands[1, ], upper = bands[2, ])
  structure(out, draws = draws, draw_rows = pick, level = level)
}

# One row per library output (library order): `x` (the setting's row, or
# `setting`, see setting_column()), the x columns and `t`.
library_cells <- function(lib) setting_cells(lib, seq_len(lib_n_x(lib)))

# Does the fit model a discrepancy (a gp_discrepancy() with a ratio > 0)?
has_discrepancy <- function(fit) {
  !is.null(fit$setup$discrepancy) && any(fit$setup$discrepancy$ratio > 0)
}

assert_discrepancy_fit <- function(fit) {
  if (!inherits(fit, "griddy_fit")) {
    griddy_abort("`fit` must be a griddy_fit from calibrate(); received ", class(fit)[1], ".",
                 class = "input")
  }
  if (!has_discrepancy(fit)) {
    griddy_abort("`fit` has no discrepancy: make it with `calibrate(..., discrepancy = ",
                 "gp_discrepancy())` (with a ratio grid that holds positive values).",
                 class = "input")
  }
  invisible(fit)
}

# `ndraws` of the fit's kept draws (rows of fit$draws), evenly spaced.
evenly_spaced_draws <- function(fit, ndraws) {
  unique(round(seq(1, nrow(fit$draws), length.out = min(ndraws, nrow(fit$draws)))))
}

# The posterior mean of the simulator's outputs (library order), over the
# kept draws.
posterior_mean_outputs <- function(fit) {
  freq <- tabulate(fit$draws$run, nbins = lib_n_runs(fit$library))
  visited <- which(freq > 0)
  colSums(lib_outputs(fit$library, visited) * (freq[visited] / sum(freq)))
}

# The residuals y - g_i of the fit's runs `runs` (one row per run).
run_residuals <- function(fit, runs) {
  matrix(fit$y_field, length(runs), length(fit$y_field), byrow = TRUE) -
    lib_outputs(fit$library, runs)
}

# The fit's discrepancy kernels (discrepancy_kernels()), for delta_law():
# NULL when its law comes from the setup's low-rank factors, which need no
# dense kernel (one n x n matrix per length scale, and the projection's
# products, made for nothing: 4% of a discrepancy fit at 480 outputs).
fit_kernels <- function(fit) {
  if (isTRUE(fit$setup$dense$lowrank)) return(NULL)
  discrepancy_kernels(fit$library, attr(fit$setup$discrepancy, "kernels"))
}

# The draws' precisions, one column per noise group (group order).
tau_matrix <- function(fit, rows) {
  as.matrix(fit$draws[rows, tau_columns(fit), drop = FALSE])
}

# The posterior mean and sd of delta at every library output: exact moments
# of the mixture over all kept draws, E[m] and E[m^2 + diag(P) / tau] -
# E[m]^2, with no random numbers (so calibrate()'s gap warning can use them).
discrepancy_moments <- function(fit) {
  kernels <- fit_kernels(fit)
  n <- length(fit$y_field)
  n_draws <- nrow(fit$draws)
  s1 <- numeric(n)
  s2 <- numeric(n)
  for (g in unique(fit$draws$grid_point)) {
    law <- delta_law(fit$setup, g, kernels)
    if (is.null(law)) next
    rows <- which(fit$draws$grid_point == g)
    runs <- unique(fit$draws$run[rows])
    counts <- tabulate(match(fit$draws$run[rows], runs), length(runs))
    m <- delta_means(law, run_residuals(fit, runs))
    s1 <- s1 + colSums(m * counts)
    s2 <- s2 + colSums(m^2 * counts)
    inv_tau <- colSums(1 / tau_matrix(fit, rows))
    for (k in seq_along(law$groups)) {
      grp <- law$groups[[k]]
      s2[grp$cells] <- s2[grp$cells] + delta_cov_diag(grp) * inv_tau[k]
    }
  }
  mean <- s1 / n_draws
  list(mean = mean, sd = sqrt(pmax(s2 / n_draws - mean^2, 0)))
}

# Draws of delta (one row per row of fit$draws in `pick`, one column per
# library output): the conditional mean plus N(0, tau^-1 P) drawn through
# P's eigen-decomposition (P is often numerically singular, see delta_cov()).
discrepancy_draws <- function(fit, pick) {
  kernels <- fit_kernels(fit)
  d <- fit$draws[pick, ]
  tau <- tau_matrix(fit, pick)
  out <- matrix(0, length(pick), length(fit$y_field))
  for (g in unique(d$grid_point)) {
    law <- delta_law(fit$setup, g, kernels)
    if (is.null(law)) next
    rows <- which(d$grid_point == g)
    runs <- unique(d$run[rows])
    out[rows, ] <- delta_means(law, run_residuals(fit, runs))[match(d$run[rows], runs), ,
                                                             drop = FALSE]
    for (k in seq_along(law$groups)) {
      grp <- law$groups[[k]]
      L <- sqrt_psd(delta_cov(grp))
      Z <- matrix(stats::rnorm(length(rows) * ncol(L)), length(rows))
      out[rows, grp$cells] <- out[rows, grp$cells] + tcrossprod(Z, L) / sqrt(tau[rows, k])
    }
  }
  out
}

# The symmetric square root V diag(sqrt(max(e, 0))) V' of the symmetric PSD
# matrix P = V diag(e) V': the one square root that does not depend on which
# eigenvectors LAPACK picks, so a draw Z P^1/2 moves with P only. (A factor
# V diag(sqrt(e)) turns with V, whose signs and, for close eigenvalues,
# directions are accidents of rounding: a change in the last bit of P
# changed the draws of delta for the same seed.)
sqrt_psd <- function(P) {
  e <- eigen(P, symmetric = TRUE)
  tcrossprod(sweep(e$vectors, 2, sqrt(sqrt(pmax(e$values, 0))), "*"))
}

# ---- where ---------------------------------------------------------------------

# How clearly delta is not 0 at each library output: |mean| / sd (0 where
# the sd is 0, as at lambda = 0). `post` holds discrepancy_moments()'s mean
# and sd. "Clear" is beyond the normal quantile of `level`: a pointwise band
# from the mixture's moments, exact and free of random numbers.
clearness <- function(post) ifelse(post$sd > 0, abs(post$mean) / post$sd, 0)

is_clear <- function(z, level) z > stats::qnorm(1 - (1 - level) / 2)

# Where delta is clearly not zero: the stretches of t within each x setting
# whose outputs are all clear, as a data.frame with the setting's label, the
# t range, the peak |mean| / sd (`z`) and the mean there, clearest first.
# `post` holds library_cells() columns plus `mean` and `sd`.
discrepancy_regions <- function(post, lib, level = 0.95) {
  z <- clearness(post)
  clear <- is_clear(z, level)
  # a run of consecutive clear outputs within one x setting is one region
  same_setting <- c(FALSE, post$x[-1] == post$x[-length(post$x)])
  starts <- clear & !(c(FALSE, clear[-length(clear)]) & same_setting)
  cells <- which(clear)
  if (length(cells) == 0L) {
    return(data.frame(setting = character(0), t_from = numeric(0), t_to = numeric(0),
                      z = numeric(0), mean = numeric(0)))
  }
  labels <- setting_labels(lib)
  regions <- do.call(rbind, lapply(split(cells, cumsum(starts)[clear]), function(i) {
    peak <- i[which.max(z[i])]
    data.frame(setting = labels[post$x[peak]], t_from = min(post$t[i]), t_to = max(post$t[i]),
               z = z[peak], mean = post$mean[peak])
  }))
  regions <- regions[order(-regions$z), , drop = FALSE]
  rownames(regions) <- NULL
  regions
}

# The "where" of the gap in words, from discrepancy_moments(): for the x
# settings with clear outputs (at most `top`, clearest first) the t range
# of those outputs, how many there are and the mean at the clearest; when
# none is clear, where |mean| / sd peaks.
discrepancy_where_text <- function(fit, level = 0.95, top = 3L) {
  lib <- fit$library
  post <- data.frame(x = rep(seq_len(lib_n_x(lib)), each = lib_n_t(lib)),
                     t = rep(lib_t(lib), lib_n_x(lib)), discrepancy_moments(fit))
  z <- clearness(post)
  clear <- is_clear(z, level)
  band <- paste0("The discrepancy's ", format(100 * level), "% band ")
  if (!any(clear)) {
    i <- which.max(z)
    return(paste0(band, "holds 0 everywhere; |mean| / sd is largest (",
                  format(z[i], digits = 2), ") at ", output_place(lib, post$x[i], post$t[i]),
                  "."))
  }
  settings <- unique(post$x[clear])
  settings <- settings[order(-vapply(settings, function(s) max(z[clear & post$x == s]), 0))]
  parts <- vapply(utils::head(settings, top), function(s) {
    i <- which(clear & post$x == s)
    peak <- i[which.max(z[i])]
    paste0(output_place(lib, s, range(post$t[i])), " (", length(i), " output",
           if (length(i) > 1L) "s", "; mean ", format(post$mean[peak], digits = 2),
           if (lib_n_t(lib) > 1L) paste0(" at t = ", format(post$t[peak], digits = 3)), ")")
  }, "")
  more <- length(settings) - length(parts)
  paste0(band, "excludes 0 at ", sum(clear), " of ", length(clear), " outputs, clearest at ",
         paste(parts, collapse = "; "),
         if (more > 0L) paste0("; and ", more, " more setting", if (more > 1L) "s"), ".")
}

# "amp = 1.5, t in [0.8, 2]": x setting `x` (a row) and the t value or range
# `t`, each left out when the library has only one.
output_place <- function(lib, x, t) {
  t <- unique(range(t))
  t_part <- if (lib_n_t(lib) == 1L) NULL else if (length(t) == 1L) {
    paste0("t = ", format(t, digits = 3))
  } else {
    paste0("t in [", format(t[1], digits = 3), ", ", format(t[2], digits = 3), "]")
  }
  paste(c(if (lib_n_x(lib) > 1L) setting_labels(lib)[x], t_part), collapse = ", ")
}
