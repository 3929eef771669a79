# The off-grid bench runs of the gap validation, condensed for the
# gap-diagnosis vignette: inst/extdata/gap_offgrid_bench.csv.gz, one row per
# trial (variant, system, scenario, seed, truth, answer, reason, max_runs).
#
# The three files bench/results/gap-offgrid-*.csv.gz were written on
# 2026-11-22 (commit 121bf7f) by data-raw/gap-validation.R in its subset mode,
# 20 trials per scenario (seeds 1001-1020 tyre, 2001-2020 piston), before the
# final confounding screen and refine() of the shipped study:
#   asis          GAP_SCENARIOS=T0b,T1b,P0b,P1b GAP_MAX_RUNS=0 (libraries as they are)
#   matched       GAP_SCENARIOS=T0b,T1b,P0b,P1b (matched resolution, max_runs 2000)
#   matched-where GAP_SCENARIOS=T0b,T1b, matched, with the block check under the
#                 predicted runs' own covariance (as the shipped study does)
# with GAP_TRIALS_TYRE=20 GAP_TRIALS_PISTON=20 GAP_OUT=bench/results/gap-offgrid-<variant>.csv.gz
# (the settings are read off the files: their seeds and max_runs column).
# This script reruns nothing: Rscript data-raw/gap-offgrid.R (seconds).

library(data.table)

files <- Sys.glob("bench/results/gap-offgrid-*.csv.gz")
trials <- rbindlist(lapply(files, function(f) {
  d <- fread(f)
  d[, variant := sub("^gap-offgrid-(.*)\\.csv\\.gz$", "\\1", basename(f))]
  d[, .(variant, system, scenario, seed, truth, answer, reason, max_runs)]
}))
setorder(trials, variant, system, scenario, seed)
print(trials[, .N, by = .(variant, scenario, answer)])
fwrite(trials, "inst/extdata/gap_offgrid_bench.csv.gz")
