# Speed of calibrate() against a plain-R loop of the thesis's Appendix A
# sampler, on the thesis's chosen configuration: 59,319 runs (39 per
# parameter), 54 data points, 35,000 iterations (burn-in 15,000), rho fixed at
# 0 as in chapters 3-4. The library is a smooth synthetic function of three
# parameters (the piston stand-in is not needed to time the sampler).
#
# Usage, from the package root after installing griddy:
#   Rscript bench/sampler-speed.R
# Writes bench/results/sampler-speed.csv and prints the table.
library(griddy)

n_per_dim <- 39
n_iter <- 35000
burn_in <- 15000
grid <- expand.grid(h1 = seq(13.85, 11984.70, length.out = n_per_dim),
                    h2 = seq(8.61, 11977.45, length.out = n_per_dim),
                    h3 = seq(35.33, 12002.49, length.out = n_per_dim))
locations <- seq(0, 1, length.out = 54)
response <- function(h) {
  outer(500 / sqrt(1 + h[, 1] / 1000), exp(-locations)) +
    outer(300 / sqrt(1 + h[, 2] / 1000), sin(3 * locations)) +
    outer(200 / sqrt(1 + h[, 3] / 1000), locations^2)
}
y <- response(as.matrix(grid))
lib <- sim_library(grid, y, x = data.frame(location = locations))
set.seed(1)
y_obs <- drop(response(cbind(1000, 3000, 2000))) + rnorm(54, sd = sqrt(0.4))
field <- field_data(y_obs)

# The thesis's Appendix A loop in plain R: C precomputed once (vectorised over
# runs), then per iteration an inverse-CDF draw over all runs and a Gamma draw.
thesis_plain_r <- function(Y, y, n_iter, burn_in, a = 1e-9, b = 1e-9) {
  C <- rowSums((Y - rep(y, each = nrow(Y)))^2)
  n <- length(y)
  tau <- 1
  keep <- integer(n_iter - burn_in)
  for (it in seq_len(n_iter)) {
    lp <- -tau / 2 * C
    p <- exp(lp - max(lp))
    cdf <- cumsum(p) / sum(p)
    run <- which(cdf > runif(1))[1]
    tau <- rgamma(1, a + n / 2, b + C[run] / 2)
    if (it > burn_in) keep[it - burn_in] <- run
  }
  keep
}

time_it <- function(expr) {
  gc()
  t0 <- proc.time()[["elapsed"]]
  force(expr)
  proc.time()[["elapsed"]] - t0
}

set.seed(2)
t_plain <- time_it(plain <- thesis_plain_r(lib$y, y_obs, n_iter, burn_in))
t_thesis <- time_it(fit_thesis <- calibrate(lib, field, n_iter = n_iter, burn_in = burn_in,
                                            update = "thesis", seed = 3))
t_collapsed <- time_it(fit_collapsed <- calibrate(lib, field, n_iter = n_iter, burn_in = burn_in,
                                                  seed = 3))

results <- data.frame(
  method = c("plain R loop (thesis Appendix A)", "calibrate(update = \"thesis\")",
             "calibrate(update = \"collapsed\")"),
  runs = nrow(lib$y), data_points = 54, iterations = n_iter,
  seconds = c(t_plain, t_thesis, t_collapsed),
  precompute_s = c(NA, fit_thesis$runtime[["precompute"]], fit_collapsed$runtime[["precompute"]]),
  sampling_s = c(NA, fit_thesis$runtime[["sampling"]], fit_collapsed$runtime[["sampling"]])
)
results$speedup_vs_plain_r <- t_plain / results$seconds
results$modal_run_agrees <- c(NA,
  which.max(tabulate(fit_thesis$draws$run, nrow(lib$y))) == which.max(tabulate(plain, nrow(lib$y))),
  which.max(tabulate(fit_collapsed$draws$run, nrow(lib$y))) == which.max(tabulate(plain, nrow(lib$y))))
results$date <- format(Sys.Date())
results$machine <- paste(R.version.string, "/", parallel::detectCores(), "cores")
print(results[, c("method", "seconds", "precompute_s", "sampling_s", "speedup_vs_plain_r",
                  "modal_run_agrees")], digits = 3, row.names = FALSE)
dir.create("bench/results", showWarnings = FALSE, recursive = TRUE)
data.table::fwrite(results, "bench/results/sampler-speed.csv")
