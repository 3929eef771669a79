# Many parameters (issue 24): refine() with the simulator at p = 4, 6, 8 on
# a cheap smooth simulator of our own, and a bimodal variant.
#   smooth-p: 80 data points, y_i = sin(pi g_i . theta) + 0.5 exp(h_i . theta / 2)
#             with fixed random g_i, h_i; theta in [0, 1]^p; the last two of
#             p >= 6 parameters weakly identified (their g, h scaled by 0.15);
#             noise sd 0.05; a 2,000-run Latin hypercube library, the truth
#             inside (a Latin hypercube point of [0.15, 0.85]^p).
#   sharp-p:  smooth-p with 200 data points and noise sd 0.01 (a posterior
#             about 11 times narrower).
#   bimodal-p: smooth-p with th1 entering as 4 (th1 - 0.5)^2, so th1 and
#             1 - th1 fit equally: two modes of equal mass (truth th1 in
#             0.5 + [0.15, 0.35]); `mirror_mass` is the fit's mass on th1 < 0.5.
# Reference posterior: importance sampling with the exact simulator, from a t
# proposal (df 5) at the least-squares fit with twice its Laplace covariance,
# 40,000 draws, uniform prior on the range, likelihood (SS)^(-n/2) as
# griddy's with a vague noise prior; for bimodal-p, mirrored in th1.
# (Systems, reference and trial in bench/many-parameters-systems.R.)
# Run: Rscript bench/many-parameters.R [system] [trials] [max_runs]
#   e.g. Rscript bench/many-parameters.R smooth-8 4 20000
# `seconds` is calibrate() plus refine(); `simulator_seconds` the simulator's
# share; `plain_*` the plain fit on the 2,000-run library.
# writes bench/results/many-parameters-<system>.csv
args <- commandArgs(trailingOnly = TRUE)
system_name <- if (length(args) >= 1) args[1] else "smooth-4"
n_trials <- if (length(args) >= 2) as.integer(args[2]) else 3L
max_runs <- if (length(args) >= 3) as.integer(args[3]) else 20000L
# GRIDDY_LIB=<library>: an installed build (-O2), its internals attached;
# GRIDDY_TAG: a suffix for the results file
if (nzchar(Sys.getenv("GRIDDY_LIB"))) {
  library(griddy, lib.loc = Sys.getenv("GRIDDY_LIB"))
  attach(asNamespace("griddy"), name = "griddy_internals", warn.conflicts = FALSE)
} else {
  pkgload::load_all(".", quiet = TRUE)
}
# the systems, the reference posterior and one_trial()
source("bench/many-parameters-systems.R")

run_system <- function(sys, n_trials, n_lib = 2000L) {
  lib <- lhs_library(sys, n_lib)
  do.call(rbind, lapply(seq_len(n_trials), function(i) {
    out <- one_trial(sys, i, lib, max_runs, system_name)
    print(out[, c("trial", "parameter", "covered", "ref_covered", "width_ratio",
                  "effective_runs", "pareto_k", "warned", "runs_added", "reason",
                  "seconds")], digits = 3)
    out
  }))
}

if (sys.nframe() == 0L && n_trials > 0L) {
  sys <- system_by_name(system_name)
  res <- run_system(sys, n_trials)
  dir.create("bench/results", showWarnings = FALSE)
  data.table::fwrite(res, file.path("bench/results",
                                    paste0("many-parameters-", system_name,
                                           Sys.getenv("GRIDDY_TAG"), ".csv")))
  dt <- data.table::as.data.table(res)
  print(dt[, .(pairs = .N, plain_coverage = mean(plain_covered), coverage = mean(covered),
               ref_coverage = mean(ref_covered),
               median_width_ratio = median(width_ratio),
               median_width_ratio_ref_covered = median(width_ratio[ref_covered]),
               missed_unwarned = sum(!covered & !warned),
               missed_unwarned_ref_covered = sum(!covered & !warned & ref_covered),
               median_seconds = median(unique(data.table::data.table(trial, seconds))$seconds))])
  if (isTRUE(sys$mirror)) print(unique(dt[, .(trial, mirror_mass, warned)]))
  print(unique(dt[, .(trial, runs_added, reason, seconds, simulator_seconds,
                      ms_per_run_outside = 1000 * (seconds - simulator_seconds) / runs_added,
                      effective_runs, pareto_k)]))
  cat("load:", system("uptime", intern = TRUE), "\n")
}
