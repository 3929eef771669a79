#' Posterior predictive at the field's settings
#'
#' The simulator outputs at the drawn library runs (the calibrated model), and
#' the same with the fitted misfit added: noise drawn from
#' \eqn{N(0, \tau^{-1} R_x \otimes R_t)} at each draw's \eqn{\tau} and
#' \eqn{\rho}. Compare the second with the field data for a posterior
#' predictive check.
#'
#' @param object A `griddy_fit` from [calibrate()].
#' @param level Probability of the central intervals.
#' @param ndraws How many draws (evenly spaced over the kept ones) to add noise
#'   to for the predictive bounds; the mean and the bounds without noise use
#'   every kept draw.
#' @param seed `NULL`, or a seed for the noise draws of this call only.
#' @param ... Ignored.
#' @return A data.frame with one row per field measurement, in the library's
#'   order: `x` (the row of the library's x settings), the x columns, `t`,
#'   `observed` (the field data), `mean`, `lower` and `upper` (the simulator
#'   outputs at the drawn runs) and `pred_lower`, `pred_upper` (with noise).
#' @examples
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 1000, burn_in = 200, seed = 1)
#' head(predict(fit, ndraws = 200, seed = 1))
#' @export
predict.griddy_fit <- function(object, level = 0.95, ndraws = 1000, seed = NULL, ...) {
  assert_level(level)
  ndraws <- assert_count(ndraws, "ndraws")
  lib <- object$library
  probs <- c((1 - level) / 2, 1 - (1 - level) / 2)
  freq <- tabulate(object$draws$run, nbins = lib_n_runs(lib))
  visited <- which(freq > 0)
  Y <- lib_outputs(lib, visited)
  w <- freq[visited] / sum(freq)
  bounds <- apply(Y, 2, weighted_quantile, w = w, probs = probs)
  pick <- unique(round(seq(1, nrow(object$draws), length.out = min(ndraws, nrow(object$draws)))))
  noisy <- with_seed(seed, noisy_outputs(object, pick))
  pred <- apply(noisy, 2, stats::quantile, probs = probs, names = FALSE)
  out <- data.frame(x = rep(seq_len(lib_n_x(lib)), each = lib_n_t(lib)))
  if (!is.null(lib$x)) out <- cbind(out, lib$x[out$x, , drop = FALSE])
  out <- cbind(out, t = rep(lib$t, lib_n_x(lib)), observed = object$y_field,
               mean = colSums(Y * w), lower = bounds[1, ], upper = bounds[2, ],
               pred_lower = pred[1, ], pred_upper = pred[2, ])
  rownames(out) <- NULL
  out
}

weighted_quantile <- function(v, w, probs) {
  o <- order(v)
  cw <- cumsum(w[o])
  v[o][vapply(probs, function(p) which(cw >= p - 1e-12)[1], integer(1))]
}

# Library outputs at the chosen draws plus N(0, R_x (x) R_t / tau) noise: one
# row per draw. Noise is built as Z -> AR(1) recursion over t -> times chol(R_x).
noisy_outputs <- function(fit, pick) {
  lib <- fit$library
  setup <- fit$problem$setup
  n_x <- lib_n_x(lib)
  n_t <- lib_n_t(lib)
  d <- fit$draws[pick, ]
  n_gx <- dim(setup$Rx_inv)[3]
  combos <- expand.grid(setup$rho_x, KEEP.OUT.ATTRS = FALSE)
  out <- lib_outputs(lib, d$run)
  for (g in unique(d$rho)) {
    rows <- which(d$rho == g)
    gx <- (g - 1L) %% n_gx + 1L
    gt <- (g - 1L) %/% n_gx + 1L
    U <- chol(corr_x(lib$x, unlist(combos[gx, , drop = FALSE]), setup$x_power))
    phi <- setup$phi[, gt]
    E <- matrix(stats::rnorm(n_t * n_x * length(rows)), n_t)
    for (j in seq_len(n_t - 1L)) E[j + 1L, ] <- phi[j] * E[j, ] + sqrt(1 - phi[j]^2) * E[j + 1L, ]
    for (m in seq_along(rows)) {
      block <- E[, (m - 1L) * n_x + seq_len(n_x), drop = FALSE] %*% U
      out[rows[m], ] <- out[rows[m], ] + as.vector(block) / sqrt(d$tau[rows[m]])
    }
  }
  out
}
