# Quick timings of the precompute of C (issue 15), for development; the
# benchmarks proper are in bench/. Each call times one case in this process:
#   Rscript tools/measure-speed.R rhox K [threads]   # 39^3 runs x 54 locations with 3
#                                                    # coordinates as x, K rho_x values per
#                                                    # coordinate (K^3 grid points)
#   Rscript tools/measure-speed.R fixed [threads]    # 10^6 runs x 54 outputs, rho fixed,
#                                                    # against one pass over the outputs
#   Rscript tools/measure-speed.R big [threads] [update]  # 10^6 runs x 1,000 grid points:
#                                                    # peak memory (update "collapsed" or "thesis")
# Load with R_LIBS pointing at the griddy to measure.
suppressPackageStartupMessages(library(griddy))
source("bench/helpers.R")
args <- commandArgs(TRUE)
threads <- if (length(args) >= 2 && args[1] != "rhox") as.integer(args[2]) else
  if (length(args) >= 3) as.integer(args[3]) else NA
if (!is.na(threads)) options(griddy.threads = threads)
cat(machine_note(), "\n")

thesis_x_library <- function(theta) {
  set.seed(1)
  x <- data.frame(x1 = runif(54), x2 = runif(54), x3 = runif(54))
  loc <- seq(0, 1, length.out = 54)
  y <- matrix(0, nrow(theta), 54)
  for (from in seq(1, nrow(theta), by = 1e5)) {
    rows <- from:min(nrow(theta), from + 1e5 - 1)
    y[rows, ] <- thesis_response(as.matrix(theta[rows, ]), loc)
  }
  list(lib = sim_library(theta, y, x = x),
       field = field_data(matrix(thesis_field(54), 54, 1), x = x))
}

if (args[1] == "rhox") {
  k <- as.integer(args[2])
  case <- thesis_x_library(thesis_theta(n_per_dim = 39))
  rho_x <- seq(0.1, 0.9, length.out = k)
  secs <- time_it(fit <- suppressWarnings(calibrate(case$lib, case$field, rho_x = rho_x,
                                                    seed = 1)))
  cat(sprintf("rho_x %d^3 = %d grid points: calibrate %.2f s, precompute %.2f s, sampling %.2f s, peak %.0f MB\n",
              k, k^3, secs, fit$runtime[["precompute"]], fit$runtime[["sampling"]], peak_mb()))
  saveRDS(fit$C, sprintf("/tmp/speed-C-rhox%d-%s.rds", k,
                         if (is.na(threads)) "default" else threads))
} else if (args[1] == "fixed") {
  N <- 1e6
  theta <- thesis_theta(n_runs = N)
  loc <- seq(0, 1, length.out = 54)
  y <- matrix(0, N, 54)
  for (from in seq(1, N, by = 1e5)) {
    rows <- from:min(N, from + 1e5 - 1)
    y[rows, ] <- thesis_response(as.matrix(theta[rows, ]), loc)
  }
  lib <- sim_library(theta, y, t = loc)
  rm(y)
  field <- field_data(thesis_field(54))
  pass <- time_it(for (r in 1:5) sum(lib$y)) / 5
  for (u in c("collapsed", "thesis")) {
    pre <- replicate(3, suppressWarnings(calibrate(lib, field, n_iter = 2000, burn_in = 100,
                                                   update = u, seed = 1))$runtime[["precompute"]])
    cat(sprintf("10^6 runs, rho fixed, %s: precompute %.3f s (min of 3; %s), one pass %.3f s, ratio %.2f\n",
                u, min(pre), paste(format(pre, digits = 3), collapse = " "), pass, min(pre) / pass))
  }
} else if (args[1] == "big") {
  theta <- thesis_theta(n_runs = 1e6)
  case <- thesis_x_library(theta)
  rm(theta)
  gc()
  reset_peak()
  before <- rss_mb()
  update <- if (length(args) >= 3) args[3] else "collapsed"
  secs <- time_it(fit <- suppressWarnings(calibrate(case$lib, case$field,
                                                    rho_x = seq(0.1, 0.9, length.out = 10),
                                                    update = update, seed = 1)))
  cat(sprintf("10^6 runs x 1,000 grid points, %s update: calibrate %.1f s (precompute %.1f s), resident before %.0f MB, peak %.0f MB\n",
              update, secs, fit$runtime[["precompute"]], before, peak_mb()))
  print(fit)
}
