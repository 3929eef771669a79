# Side by side in one run: calibrate() (both updates) against the plain-R
# Appendix A loop, on the thesis's configurations.
#  * Chapter 3: 27 ... 103,823 runs (3 ... 47 values per parameter) x 54 data
#    points x 35,000 iterations (burn-in 15,000), rho fixed at 0.
#  * Chapter 5 (tyre): 6,000 runs x 1,500 data points (3 cleat heights x 500
#    times), rho_t on a grid of 5 points, 50,000 iterations.
# The plain-R loop runs the full iteration count except at 103,823 runs,
# where it runs 10,000 iterations and its time is scaled by 3.5 (its cost per
# iteration is constant; the column `plain_iterations` says what ran).
# Times include the precomputation (the plain loop's C; calibrate()'s setup,
# C and sorting).
#
# Usage, from the package root after installing griddy:
#   Rscript bench/thesis-configs.R
# Writes bench/results/thesis-configs.csv and prints the table.
suppressPackageStartupMessages(library(griddy))
source("bench/helpers.R")
note <- machine_note()

one_config <- function(label, lib, field, y_obs, rho_t, n_iter, burn_in, plain_iter) {
  n <- length(y_obs)
  set.seed(2)
  t_plain <- time_it({
    pq <- if (identical(rho_t, 0)) {
      list(C = matrix(rowSums((lib$y - rep(y_obs, each = nrow(lib$y)))^2)), logdet = 0)
    } else {
      plain_quad_forms(lib$y, y_obs, nrow(lib$x), lib$t, rho_t)
    }
    plain <- thesis_plain_r(pq$C, pq$logdet, n, plain_iter, min(burn_in, plain_iter - 1))
  })
  t_plain_scaled <- t_plain * n_iter / plain_iter
  fits <- lapply(c(thesis = "thesis", collapsed = "collapsed"), function(u) {
    secs <- time_it(fit <- suppressWarnings(
      calibrate(lib, field, rho_t = rho_t, n_iter = n_iter, burn_in = burn_in, update = u,
                seed = 3)))
    list(secs = secs, fit = fit)
  })
  modal <- function(r) which.max(tabulate(r, nrow(lib$y)))
  exact_modal <- which.max(posterior_exact(lib, field, rho_t = rho_t)$run)
  data.frame(
    config = label, runs = nrow(lib$y), data_points = n, grid_points = length(rho_t),
    iterations = n_iter, plain_iterations = plain_iter,
    plain_r_s = t_plain_scaled,
    thesis_s = fits$thesis$secs, collapsed_s = fits$collapsed$secs,
    thesis_precompute_s = fits$thesis$fit$runtime[["precompute"]],
    collapsed_precompute_s = fits$collapsed$fit$runtime[["precompute"]],
    speedup_thesis = t_plain_scaled / fits$thesis$secs,
    speedup_collapsed = t_plain_scaled / fits$collapsed$secs,
    thesis_head_runs = mean(fits$thesis$fit$head_length),
    modal_run_agrees = modal(fits$thesis$fit$draws$run) == modal(plain) &&
      modal(fits$collapsed$fit$draws$run) == modal(plain),
    # the most probable run of the exact posterior (posterior_exact())
    plain_modal_is_exact = modal(plain) == exact_modal,
    griddy_modal_is_exact = modal(fits$thesis$fit$draws$run) == exact_modal &&
      modal(fits$collapsed$fit$draws$run) == exact_modal
  )
}

rows <- list()
y_obs <- thesis_field(54)
locations <- seq(0, 1, length.out = 54)
for (k in c(3, 4, 5, 6, 7, 8, 9, 10, 15, 22, 27, 32, 39, 47)) {
  theta <- thesis_theta(n_per_dim = k)
  lib <- sim_library(theta, thesis_response(as.matrix(theta), locations),
                     x = data.frame(location = locations))
  plain_iter <- if (nrow(theta) > 60000) 10000 else 35000
  rows[[length(rows) + 1]] <- one_config(paste0("ch. 3, ", k, "^3 runs"), lib,
                                         field_data(y_obs), y_obs, 0, 35000, 15000, plain_iter)
  print(rows[[length(rows)]][, c("runs", "plain_r_s", "thesis_s", "collapsed_s")])
}

# Chapter 5: Fiala library (Latin hypercube), PAC2002 "measurements" plus noise
set.seed(5)
# point-follower contact, as when bench/results/thesis-configs.csv was made
t_lib <- time_it(tyre <- tyre_library(6000, model = "fiala", contact = "point"))
truth <- tyre_cleat_model(210, 0.5, model = "pac2002")
y_tyre <- as.vector(truth) + rnorm(length(truth), sd = 0.01 * max(abs(truth)))
field_tyre <- field_data(matrix(y_tyre, nrow = 3, byrow = TRUE), x = tyre$x, t = tyre$t)
rows[[length(rows) + 1]] <- one_config("ch. 5 tyre, rho_t grid", tyre, field_tyre, y_tyre,
                                       c(0, 0.25, 0.5, 0.75, 0.9), 50000, 15000, 50000)

results <- do.call(rbind, rows)
results$machine <- note
results$date <- format(Sys.Date())
print(results[, c("config", "runs", "data_points", "plain_r_s", "thesis_s", "collapsed_s",
                  "speedup_thesis", "speedup_collapsed", "thesis_head_runs",
                  "modal_run_agrees", "plain_modal_is_exact", "griddy_modal_is_exact")], digits = 3, row.names = FALSE)
cat("tyre library generation:", round(t_lib, 1), "s\n", note, "\n")
dir.create("bench/results", showWarnings = FALSE, recursive = TRUE)
data.table::fwrite(results, "bench/results/thesis-configs.csv")
