# Many parameters without a simulator (issue 24): refine(fit, max_runs =
# 3000) on bench/many-parameters.R's smooth-8 system, trial 1 (its library,
# truth and noise). Writes bench/results/many-parameters-emulator.csv.
# Run: Rscript bench/many-parameters-emulator.R
n_trials <- 0L
source("bench/many-parameters.R")
sys <- system_by_name("smooth-8")
set.seed(2024)
theta <- lhs(2000, sys$lower, sys$upper, sys$names)
lib <- sim_library(theta, sys$sim(theta))
set.seed(1001)
truth <- unlist(lhs(1, rep(0.15, 8), rep(0.85, 8), sys$names))
y <- sys$sim(matrix(truth, 1))[1, ] + rnorm(ncol(lib$y), sd = sys$sd)
field <- field_data(matrix(y, 1), t = lib$t)
fit <- suppressWarnings(calibrate(lib, field, n_iter = 1000, burn_in = 200, seed = 1))
warnings_seen <- character()
t0 <- proc.time()[["elapsed"]]
r <- withCallingHandlers(suppressMessages(refine(fit, max_runs = 3000, seed = 1)),
                         warning = function(w) {
                           warnings_seen <<- c(warnings_seen, if (inherits(w, "griddy_warning")) class(w)[1] else conditionMessage(w))
                           invokeRestart("muffleWarning")
                         })
secs <- proc.time()[["elapsed"]] - t0
tab <- resolution_limited(r)
res <- data.frame(parameter = tab$parameter, truth = truth, lower = tab$lower, upper = tab$upper,
                  covered = tab$lower <= truth & truth <= tab$upper,
                  effective_runs = tab$effective_runs, limited = tab$limited,
                  runs_added = r$refinement$runs_added, reason = r$refinement$reason,
                  emulation_error = r$refinement$emulation_error,
                  warnings = paste(warnings_seen, collapse = " "), seconds = secs,
                  machine = paste("load", readLines("/proc/loadavg")))
print(res, digits = 3)
data.table::fwrite(res, "bench/results/many-parameters-emulator.csv")
