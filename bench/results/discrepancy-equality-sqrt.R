sqrt_psd <- function(P) {
  e <- eigen(P, symmetric = TRUE)
  tcrossprod(sweep(e$vectors, 2, sqrt(sqrt(pmax(e$values, 0))), "*"))
}
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
