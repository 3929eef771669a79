# Issue 34, item 1: the time of predict(fit, newdata, simulator = ) at x
# settings the library does not hold, on a 10^4-run library with a
# discrepancy. Library: theta = (a, b) on a 100 x 100 grid ([0.5, 1.5] x
# [0.5, 2]), simulator y = a x exp(-b t) + 0.1 x at 5 settings x in
# [0.2, 4] and N_T (default 20) t in [0, 1]; field data from a = 1.02,
# b = 1.23 with a gap 0.05 x^2 / (1 + x) and noise sd NOISE_SD (default
# 0.3, so that the posterior spreads over a few hundred runs).
# calibrate(): gp_discrepancy() (default grid: 1 + 11 x 3 x 3 = 100
# discrepancy points), rho_t in {0, 0.5}, 5,000 iterations (1,000 burn-in).
# Timed (elapsed s, median of REPEATS calls): predict() at the library's
# settings (today's path), and at 3 new settings (x = 2.5 inside, 5 and 6
# outside) with and without the discrepancy; the simulator's own time and
# the runs it was given are recorded. Run from the package root:
#   Rscript bench/predict-new.R
# appends to bench/results/predict-new.csv.
pkgload::load_all(".", quiet = TRUE)
repeats <- as.integer(Sys.getenv("REPEATS", "3"))
noise_sd <- as.numeric(Sys.getenv("NOISE_SD", "0.3"))
x <- data.frame(x = seq(0.2, 4, length.out = 5))
n_t <- as.integer(Sys.getenv("N_T", "20"))
t <- seq(0, 1, length.out = n_t)
theta <- expand.grid(a = seq(0.5, 1.5, length.out = 100), b = seq(0.5, 2, length.out = 100))
clock <- new.env()
clock$sim <- 0
clock$runs <- 0
simulator <- function(theta, x) {
  t0 <- proc.time()[["elapsed"]]
  y <- t(mapply(function(a, b) unlist(lapply(x$x, function(v) a * v * exp(-b * t) + 0.1 * v)),
                theta$a, theta$b))
  clock$sim <- clock$sim + proc.time()[["elapsed"]] - t0
  clock$runs <- clock$runs + nrow(theta)
  matrix(y, nrow(theta))
}
lib <- sim_library(theta, simulator(theta, x), x = x, t = t)
set.seed(34)
real <- simulator(data.frame(a = 1.02, b = 1.23), x) +
  rep(0.05 * x$x^2 / (1 + x$x), each = length(t))
field <- field_data(matrix(real + rnorm(length(real), sd = noise_sd), nrow(x), byrow = TRUE),
                    x = x, t = t)
fit_time <- system.time(fit <- suppressWarnings(
  calibrate(lib, field, rho_t = c(0, 0.5), n_iter = 5000, burn_in = 1000, seed = 1,
            discrepancy = gp_discrepancy())))[["elapsed"]]
new <- data.frame(x = c(2.5, 5, 6))
time_call <- function(...) {
  times <- numeric(repeats)
  for (r in seq_len(repeats)) {
    clock$sim <- 0
    clock$runs <- 0
    times[r] <- system.time(out <- predict(fit, ..., seed = 1))[["elapsed"]]
  }
  data.frame(elapsed = stats::median(times), simulator_s = clock$sim,
             runs_simulated = clock$runs)
}
res <- rbind(
  cbind(case = "library settings (today's path)", time_call(newdata = x)),
  cbind(case = "3 new settings, discrepancy", time_call(newdata = new, simulator = simulator)),
  cbind(case = "3 new settings, discrepancy, run_mass = 1",
        time_call(newdata = new, simulator = simulator, run_mass = 1)),
  cbind(case = "3 new settings, simulator alone",
        time_call(newdata = new, simulator = simulator, discrepancy = FALSE)))
res$distinct_runs <- length(unique(fit$draws$run))
res$grid_points_visited <- length(unique(fit$draws$grid_point))
res$calibrate_s <- fit_time
res$n_t <- n_t
res$noise_sd <- noise_sd
res$machine <- paste0("load ", format(utils::read.table("/proc/loadavg")[[1]], nsmall = 2))
print(res)
out <- "bench/results/predict-new.csv"
if (file.exists(out)) res <- rbind(utils::read.csv(out)[names(res)], res)
utils::write.csv(res, out, row.names = FALSE)
