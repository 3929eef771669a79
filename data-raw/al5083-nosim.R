# Al-5083 without a simulator, issue 35 item 3: the 11-parameter
# flyer-plate runs of SEPIA (data-raw/sepia-al5083.R) through calibrate()
# and refine(fit) with no simulator, whose rounds from four parameters draw
# from the proposal and predict with one Gaussian process over all 1,000
# runs (R/refine-predict.R). Records what refine() says (reason, warnings
# with their classes, effective runs, Pareto k-hat), the time, and the
# intervals beside the shipped reference of data-raw/al5083.R (a ppgasp
# emulator of the same runs with importance sampling, in
# inst/extdata/al5083.rds). Results: inst/extdata/al5083_nosim.rds.
# Run from the package root (SEPIA_DIR as for data-raw/al5083.R):
#   Rscript data-raw/al5083-nosim.R
# Times are on a shared 2-core machine (load recorded).
pkgload::load_all(".", quiet = TRUE)
source("data-raw/sepia-al5083.R")
set.seed(20261127)
max_runs <- as.integer(Sys.getenv("AL5083_MAX_RUNS", "44000"))
conditions <- list()
keep <- function(cnd) {
  conditions[[length(conditions) + 1L]] <<- list(
    class = grep("^griddy_", class(cnd), value = TRUE)[1], message = conditionMessage(cnd))
}
quiet <- function(expr) {
  withCallingHandlers(expr,
                      warning = function(w) { keep(w); invokeRestart("muffleWarning") },
                      message = function(m) { keep(m); invokeRestart("muffleMessage") })
}
load <- scan("/proc/loadavg", what = numeric(), n = 3, quiet = TRUE)
lib <- sim_library(al_design, al_sim)
field <- field_data(al_obs, sd = al_obs_sd)
t0 <- proc.time()[["elapsed"]]
base <- quiet(calibrate(lib, field, seed = 1))
t1 <- proc.time()[["elapsed"]]
fit <- quiet(refine(base, max_runs = max_runs, seed = 1))
t2 <- proc.time()[["elapsed"]]
s <- summary(fit)
draws <- as.data.frame(fit)
parameters <- names(al_design)
tab <- resolution_limited(fit)
table <- data.frame(parameter = parameters, mean = s$estimate[match(parameters, s$parameter)],
                    sd = vapply(parameters, function(p) stats::sd(draws[[p]]), numeric(1)),
                    lower = tab$lower, upper = tab$upper, row.names = NULL)
history <- do.call(rbind, lapply(seq_along(fit$refinement$history), function(i) {
  runs <- attr(fit$refinement$history[[i]], "runs")
  data.frame(round = i - 1L, effective_runs = runs$effective_runs, pareto_k = runs$pareto_k)
}))
results <- list(
  made = format(Sys.time(), tz = "UTC", usetz = TRUE), session = R.version.string,
  max_runs = max_runs, table = table, runs = attr(tab, "runs"),
  refinement = fit$refinement[c("runs_added", "rounds", "reason", "source",
                                "emulation_error")],
  history = history, n_runs = lib_n_runs(fit$library),
  noise_scale = 1 / sqrt(s$estimate[s$parameter == "tau"]),
  conditions = conditions, seconds = c(calibrate = t1 - t0, refine = t2 - t1), load = load)
saveRDS(results, "inst/extdata/al5083_nosim.rds", compress = "xz")
print(results[c("refinement", "runs", "seconds", "load")])
print(history)
print(table, digits = 3)
