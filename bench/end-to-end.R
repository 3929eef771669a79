# Issue 22: the whole calibrate() call at 10^6 runs, rho fixed, against one
# pass over the library's memory, and print() and summary() of its fit; the
# default thread count against one thread. The library is precompute-pass.R's:
# 10^6 random runs x 54 outputs of the three-parameter test response
# (thesis_runs(), 412 MB, scattered: every run has its own values), field
# thesis_field(54), rho fixed (rho_t = 0), calibrate()'s default chain (5,000
# iterations, burn-in 1,000, when they pass its checks), one chain, collapsed update.
#
# One pass is measured two ways: R's sum() over the library's outputs (the
# definition the goals use: calibrate() within 3 of them, print() and
# summary() within one) and a plain C++ read loop over the same memory
# (griddy's unexported memory_pass_cpp(), four independent sums: the speed
# a single thread reads memory at, faster than sum(), which adds in long
# double). Times are elapsed seconds of the whole call (measure_call()),
# beside the fit's own `runtime` parts.
#
# Everything runs in one R process, repeated REPEATS times in turn, so the
# ratios compare calls made under the same load: per repeat, both passes,
# calibrate() with the default threads and with options(griddy.threads = 1)
# (which goes first alternates between repeats), then print() and summary()
# of the default fit. Medians are compared (minima are in the CSV too); the cores other
# processes kept busy are recorded (above 0.2: the machine was shared).
#
# Usage, from the package root, with griddy installed (R CMD INSTALL .):
#   Rscript bench/end-to-end.R
# Options (environment): REPEATS (default 8), E2E_RUNS (default 1e6; smaller for a smoke
# test), GRIDDY_NEW_LIB (a library holding the griddy to test), E2E_NAME (the
# results' file name, default end-to-end; end-to-end-busy is the run made with
# two CPU burners beside it: `yes > /dev/null &` twice). Writes
# bench/results/<E2E_NAME>.csv and .md. About 1-2 minutes and 1-2 GB here.
source("bench/helpers.R")
if (nzchar(new_griddy_lib())) .libPaths(c(new_griddy_lib(), .libPaths()))
suppressPackageStartupMessages(library(griddy))
n_points <- 54
n_runs <- as.numeric(Sys.getenv("E2E_RUNS", 1e6))
repeats <- as.integer(Sys.getenv("REPEATS", 8))
out_name <- file.path("bench/results", Sys.getenv("E2E_NAME", "end-to-end"))
goal_calibrate <- 3
goal_print <- 1
load_before <- load_1min()
start_note <- machine_note()

runs <- thesis_runs(n_runs, n_points)
lib <- sim_library(runs$theta, runs$y, t = runs$t)
rm(runs)
field <- field_data(thesis_field(n_points))
read_loop <- read_loop_fn()
fit_call <- function(threads) {
  old <- options(griddy.threads = threads)
  on.exit(options(old))
  measure_call(suppressWarnings(calibrate(lib, field, seed = 1, progress = FALSE)))
}

rows <- list()
others <- other_work_start()
for (r in seq_len(repeats)) {
  sum_s <- time_it(sum(lib$y))
  loop_s <- time_it(read_loop(lib$y))
  chosen <- griddy_threads()  # what the default call below uses
  # in turn first and second (the first call after the passes ran slower)
  if (r %% 2 == 1) {
    default <- fit_call(NULL)
    one <- fit_call(1L)
  } else {
    one <- fit_call(1L)
    default <- fit_call(NULL)
  }
  print_s <- time_it(utils::capture.output(print(default$value)))
  summary_s <- time_it(summary(default$value))
  rows[[r]] <- data.frame(
    repeat_no = r, sum_s = sum_s, loop_s = loop_s,
    calibrate_s = default$elapsed_s, calibrate_1thread_s = one$elapsed_s,
    t(default$value$runtime), precompute_1thread = one$value$runtime[["precompute"]],
    default_threads = chosen, print_s = print_s, summary_s = summary_s,
    peak_extra_mb = default$peak_extra_mb, load_1min = load_1min())
}
other_cores <- other_cores_since(others)
each <- do.call(rbind, rows)
med <- function(v) stats::median(v)
results <- data.frame(
  runs = n_runs, data_points = n_points, repeats = repeats,
  library_mb = 8 * n_runs * n_points / 2^20,
  sum_s = med(each$sum_s), loop_s = med(each$loop_s),
  calibrate_s = med(each$calibrate_s), calibrate_min_s = min(each$calibrate_s),
  precompute_s = med(each$precompute), sampling_s = med(each$sampling),
  checks_s = med(each$checks),
  calibrate_1thread_s = med(each$calibrate_1thread_s),
  precompute_1thread_s = med(each$precompute_1thread),
  print_s = med(each$print_s), summary_s = med(each$summary_s),
  default_threads = paste(unique(each$default_threads), collapse = ","),
  peak_extra_mb = max(each$peak_extra_mb), other_cores = other_cores,
  load_1min_before = load_before, load_1min_max = max(each$load_1min),
  machine = start_note, date = format(Sys.Date()))
results <- within(results, {
  calibrate_sum_passes <- calibrate_s / sum_s
  calibrate_loop_passes <- calibrate_s / loop_s
  print_sum_passes <- print_s / sum_s
  summary_sum_passes <- summary_s / sum_s
  default_vs_1thread <- calibrate_s / calibrate_1thread_s
  precompute_default_vs_1thread <- precompute_s / precompute_1thread_s
})
dir.create("bench/results", showWarnings = FALSE, recursive = TRUE)
data.table::fwrite(results, paste0(out_name, ".csv"))
data.table::fwrite(each, paste0(out_name, "-repeats.csv"))

passes <- function(s) paste0(fmt3(s), " s = ", format(round(s / results$sum_s, 2), nsmall = 2),
                             " sum() / ", format(round(s / results$loop_s, 2), nsmall = 2), " loop")
shown <- data.frame(
  what = c("one pass: `sum(lib$y)`", "one pass: C++ read loop",
           "`calibrate()`, default threads", "  of which precompute (validation, C, tables)",
           "  of which sampling", "  of which checks (exact margins, diagnostics, warnings)",
           "`calibrate()`, 1 thread", "`print(fit)`", "`summary(fit)`"),
  time = c(paste(fmt3(results$sum_s), "s"), paste(fmt3(results$loop_s), "s"),
           passes(results$calibrate_s), passes(results$precompute_s),
           passes(results$sampling_s), passes(results$checks_s),
           passes(results$calibrate_1thread_s), passes(results$print_s),
           passes(results$summary_s)))
md <- c(
  md_header("The whole calibrate() call at 10^6 scattered runs, rho fixed",
            "bench/end-to-end.R", start_note, c(load_before, each$load_1min), other_cores),
  "",
  paste0(format(n_runs, big.mark = ",", scientific = FALSE), " runs x ", n_points,
         " outputs (", round(results$library_mb), " MB), rho fixed, calibrate()'s default chain (5,000 iterations, burn-in ",
         "1,000, when they pass its checks, else 35,000 and 15,000), one chain; medians of ", repeats, " repeats in one process. ",
         "Elapsed time of the whole call, and in passes over the library's memory ",
         "(R's `sum()`, and a C++ read loop). Goals: `calibrate()` within ", goal_calibrate,
         " `sum()` passes, `print()` and `summary()` within ", goal_print,
         ", the default threads at most 1.2 times one thread."),
  "",
  md_table(shown),
  "",
  paste0("Default threads (`griddy_threads()`): ", results$default_threads,
         ". Default / 1 thread: `calibrate()` ", round(results$default_vs_1thread, 2),
         ", precompute ", round(results$precompute_default_vs_1thread, 2), ". Peak memory ",
         "above the start of a call: ", round(results$peak_extra_mb), " MB."))
writeLines(md, paste0(out_name, ".md"))
cat(md, sep = "\n")
