# The precompute at 10^6 runs with rho fixed against one pass over the
# library's memory (issue 15; goal: at most 1.5 passes). The library is
# scaling.R's: 10^6 random runs x 54 outputs of the three-parameter test
# response (thesis_runs(), 412 MB), field thesis_field(54), rho fixed
# (rho_t = 0), 35,000 iterations (burn-in 15,000), one chain, both updates.
# "One pass" is scaling.R's definition: one sum() over the library's outputs
# in memory (sum(lib$y)); a plain C++ read loop over the same memory
# (read_loop_fn(), griddy's memory_pass_cpp()) is reported beside it: sum()
# adds in long double and reads about 3 times slower, so passes counted in
# sum() understate the reads. Precompute is calibrate()'s own `runtime[["precompute"]]`
# (validation, C, and the sorted columns or truncated CDFs the sampler
# needs), the quantity issue 15 quotes (0.31 s against 0.107 s there).
#
# Side by side in one run, each in its own R process: the old code (griddy
# at c18971b, GRIDDY_OLD_LIB, installed on first use) and the new
# (GRIDDY_NEW_LIB, default the installed griddy; once per thread count in
# GRIDDY_NEW_THREADS, e.g. "1,2"). The pass and each update's calibrate() are
# repeated REPEATS times (default 7) alternately, and the medians compared
# (the minima are in the CSV too). The cores other processes kept busy over
# the repeats are recorded (above 0.2: the machine was shared), and the
# one-minute load average before each process as context.
#
# Usage, from the package root:
#   GRIDDY_NEW_LIB=/tmp/lib-new Rscript bench/precompute-pass.R
# Options (environment): PRECOMPUTE_IMPLEMENTATIONS (default "old,new"),
# GRIDDY_NEW_THREADS, REPEATS, PRECOMPUTE_RUNS (default 1e6; smaller for a
# smoke test). Writes bench/results/precompute-pass.csv and .md. About 2
# minutes here.
source("bench/helpers.R")
args <- commandArgs(TRUE)
goal_passes <- 1.5
n_points <- 54
n_runs <- as.numeric(Sys.getenv("PRECOMPUTE_RUNS", 1e6))
repeats <- as.integer(Sys.getenv("REPEATS", 7))

# Child: one implementation; writes <label>.csv, one row per update.
if (length(args) == 3 && args[1] == "--one") {
  label <- args[2]
  out <- args[3]
  load_before <- load_1min()
  suppressPackageStartupMessages(library(griddy))
  info <- griddy_child_setup()
  runs <- thesis_runs(n_runs, n_points)
  lib <- sim_library(runs$theta, runs$y, t = runs$t)
  rm(runs)
  field <- field_data(thesis_field(n_points))
  updates <- c("collapsed", "thesis")
  pass <- numeric(repeats)
  loop <- numeric(repeats)
  read_loop <- read_loop_fn()
  pre <- matrix(NA_real_, repeats, 2, dimnames = list(NULL, updates))
  calls <- list()
  others <- other_work_start()
  for (r in seq_len(repeats)) {
    pass[r] <- time_it(sum(lib$y))
    loop[r] <- time_it(read_loop(lib$y))
    for (u in updates) {
      calls[[u]] <- measure_call(suppressWarnings(
        calibrate(lib, field, n_iter = 35000, burn_in = 15000, update = u, seed = r,
                  progress = FALSE)))
      pre[r, u] <- calls[[u]]$value$runtime[["precompute"]]
    }
  }
  other_cores <- other_cores_since(others)  # over all repeats
  rows <- lapply(updates, function(u) {
    m <- calls[[u]]
    data.frame(implementation = label, update = u, runs = n_runs, data_points = n_points,
               info, repeats = repeats, memory_pass_s = median(pass),
               memory_pass_min_s = min(pass), precompute_s = median(pre[, u]),
               precompute_min_s = min(pre[, u]),
               passes = median(pre[, u]) / median(pass),
               read_loop_s = median(loop), loop_passes = median(pre[, u]) / median(loop),
               sampling_s = m$value$runtime[["sampling"]],
               library_mb = 8 * n_runs * n_points / 2^20,
               peak_extra_mb = m$peak_extra_mb, cpu_per_elapsed = m$cpu_s / m$elapsed_s,
               os_threads = m$os_threads, other_cores = other_cores, load_1min = load_before)
  })
  data.table::fwrite(do.call(rbind, rows), out)
  quit(save = "no")
}

impls <- strsplit(Sys.getenv("PRECOMPUTE_IMPLEMENTATIONS", "old,new"), ",")[[1]]
runs <- list()
if ("old" %in% impls) runs$old <- list(lib = old_griddy_lib(), env = character())
if ("new" %in% impls) {
  for (th in new_griddy_threads()) {
    label <- if (is.na(th)) "new" else paste0("new-", th, "threads")
    runs[[label]] <- list(lib = new_griddy_lib(),
                          env = if (is.na(th)) character() else paste0("GRIDDY_THREADS=", th))
  }
}
start_note <- machine_note()
results <- data.table::rbindlist(lapply(names(runs), function(label) {
  cat(label, "...\n")
  out <- tempfile(fileext = ".csv")
  run_child("bench/precompute-pass.R", c("--one", label, out), lib = runs[[label]]$lib,
            env = runs[[label]]$env)
  row <- data.table::fread(out)
  unlink(out)
  print(row[, .(implementation, update, memory_pass_s, precompute_s, passes, load_1min)])
  row
}))
results[, within_goal := passes <= goal_passes]
results[, shared_machine := other_cores > 0.2]
results[, machine := start_note]
results[, date := format(Sys.Date())]
dir.create("bench/results", showWarnings = FALSE, recursive = TRUE)
data.table::fwrite(results, "bench/results/precompute-pass.csv")

shown <- results[, .(
  implementation, update, `one pass (s)` = signif(memory_pass_s, 3),
  `precompute (s)` = signif(precompute_s, 3), `precompute / pass` = round(passes, 2),
  `read loop (s)` = signif(read_loop_s, 3), `precompute / loop` = round(loop_passes, 2),
  `goal <= 1.5` = within_goal, `sampling (s)` = signif(sampling_s, 2),
  `peak above start (MB)` = round(peak_extra_mb), `CPU / elapsed` = round(cpu_per_elapsed, 2),
  threads = threads_label(threads_option, griddy_threads, os_threads), `other cores` = round(other_cores, 2), `load (1 min)` = load_1min)]
md <- c(
  md_header("The precompute at 10^6 runs, rho fixed, against one pass over memory",
            "bench/precompute-pass.R", start_note, results$load_1min, results$other_cores),
  "",
  paste0(format(n_runs, big.mark = ",", scientific = FALSE), " runs x ", n_points,
         " outputs (", round(8 * n_runs * n_points / 2^20), " MB), rho fixed, 35,000 ",
         "iterations; medians of ", repeats, " repeats in one process per implementation. ",
         "One pass: `sum(lib$y)` (scaling.R's definition; single-threaded), and beside it a ",
         "C++ read loop over the same memory (`memory_pass_cpp()`). Precompute: ",
         "`fit$runtime[[\"precompute\"]]`. Goal: at most ", goal_passes, " passes."),
  "",
  md_table(shown)
)
writeLines(md, "bench/results/precompute-pass.md")
cat(md, sep = "\n")
