# refine(fit) without a simulator in 8 parameters (issue 35, item 3): the
# smooth-8 system of bench/many-parameters-systems.R (80 outputs, noise sd
# 0.05, two weakly identified parameters), a 500-run Latin hypercube library
# (seed 2024), field data and the exact-simulator reference posterior of
# trial i (seed 1000 + i), then calibrate() and refine(fit, max_runs =
# 16000) with no simulator: its rounds draw from the proposal and predict
# with one Gaussian process over the 500 runs (R/refine-predict.R).
# Per trial and parameter: the interval, whether it covers the truth, its
# width over the reference's (which knows the simulator, so a ratio above 1
# is the emulator's error, carried into the likelihood), effective runs,
# why refine() stopped, what it warned (resolution, emulation) and the time.
# Run from the package root:
#   Rscript bench/nosim-many-parameters.R [trials]
# Results: bench/results/nosim-many-parameters.csv. Times are on a shared
# 2-core machine (load recorded).
pkgload::load_all(".", quiet = TRUE)
source("bench/many-parameters-systems.R")
args <- commandArgs(trailingOnly = TRUE)
trials <- if (length(args) > 0L) as.integer(args[1]) else 4L
max_runs <- 16000L
sys <- smooth_system(8)
lib <- lhs_library(sys, 500)
out <- "bench/results/nosim-many-parameters.csv"
rows <- list()
for (i in seq_len(trials)) {
  d <- trial_data(sys, i, lib)
  warned <- character()
  t0 <- proc.time()[["elapsed"]]
  fit <- suppressWarnings(calibrate(lib, d$field, n_iter = 1000, burn_in = 200, seed = i))
  r <- withCallingHandlers(
    suppressMessages(refine(fit, max_runs = max_runs, seed = i)),
    warning = function(w) {
      warned <<- c(warned, sub("^griddy_warning_", "", grep("^griddy_warning_", class(w),
                                                              value = TRUE)[1]))
      invokeRestart("muffleWarning")
    })
  secs <- proc.time()[["elapsed"]] - t0
  tab <- resolution_limited(r)
  rows[[i]] <- data.frame(
    trial = i, parameter = tab$parameter, truth = d$truth, lower = tab$lower,
    upper = tab$upper, covered = tab$lower <= d$truth & d$truth <= tab$upper,
    ref_lower = d$ref$lower, ref_upper = d$ref$upper,
    width_ratio = (tab$upper - tab$lower) / (d$ref$upper - d$ref$lower),
    effective_runs = tab$effective_runs, pareto_k = tab$pareto_k,
    runs_added = r$refinement$runs_added, rounds = r$refinement$rounds,
    reason = r$refinement$reason, emulation_error = r$refinement$emulation_error,
    warned = paste(unique(warned), collapse = " "), seconds = secs,
    machine = paste("load", paste(round(load_average(), 2), collapse = " ")))
  utils::write.csv(do.call(rbind, rows), out, row.names = FALSE)
  message("trial ", i, ": ", r$refinement$reason, ", ", round(secs), " s, covered ",
          sum(rows[[i]]$covered), "/8, width ratio ", paste(round(range(rows[[i]]$width_ratio), 2),
                                                             collapse = "-"))
}
print(do.call(rbind, rows), digits = 3)
