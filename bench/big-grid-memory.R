# Memory that scales with the grid (issue 15, item 2): 10^6 runs x 1,000
# grid points must calibrate on a 24 GB machine, with the memory stated up
# front. The library: 10^6 random runs of the three-parameter test response
# (thesis_theta(), thesis_response()) at 54 data points, each with 3 random
# coordinates as x; one rho_x grid per coordinate, seq(0, 0.9, length.out =
# 10), every combination (1,000 grid points, as in rho-x-grid.R); field
# thesis_field(54); 35,000 iterations (burn-in 15,000), seed 1.
#
# For each update, in its own R process (so one's memory does not count in
# the other's): calibrate()'s up-front statement (the message of class
# griddy_message_memory, given before C is computed) and print(fit)'s
# "Memory:" line; what the statement adds up to (C, the run order and the
# library's outputs); the peak resident memory of the process during the
# call, above the memory before it and in all (the library is in memory
# before); elapsed, precompute and CPU seconds; the machine's memory.
#
# Only the new code: the old code (c18971b) needs C's 8 GB too, but at its
# speed on rho-x-grid.R's case (319 s for 59,319 runs) this would take about
# 90 minutes.
#
# Usage, from the package root:
#   GRIDDY_NEW_LIB=/tmp/lib-new Rscript bench/big-grid-memory.R
# Options (environment): BIG_RUNS (default 1e6; smaller for a smoke test),
# BIG_UPDATES (default "collapsed,thesis"). Writes
# bench/results/big-grid-memory.csv and .md. About 5 minutes here.
source("bench/helpers.R")
args <- commandArgs(TRUE)
n_runs <- as.numeric(Sys.getenv("BIG_RUNS", 1e6))
n_points <- 54
rho_values <- seq(0, 0.9, length.out = 10)

# The library: thesis_runs()'s outputs, with 3 coordinates per data point as x.
big_case <- function() {
  runs <- thesis_runs(n_runs, n_points)
  set.seed(1)
  x <- data.frame(x1 = runif(n_points), x2 = runif(n_points), x3 = runif(n_points))
  list(lib = griddy::sim_library(runs$theta, runs$y, x = x),
       field = griddy::field_data(matrix(thesis_field(n_points), n_points, 1), x = x),
       grids = setNames(rep(list(rho_values), 3), names(x)))
}

mem_total_gb <- function() {
  s <- grep("^MemTotal", readLines("/proc/meminfo"), value = TRUE)
  as.numeric(sub("[^0-9]*([0-9]+).*", "\\1", s)) * 1024 / 1e9
}

# Child: one update; writes one row.
if (length(args) == 3 && args[1] == "--one") {
  update <- args[2]
  out <- args[3]
  load_before <- load_1min()
  suppressPackageStartupMessages(library(griddy))
  info <- griddy_child_setup()
  case <- big_case()
  statement <- NA_character_
  m <- measure_call(withCallingHandlers(
    suppressWarnings(calibrate(case$lib, case$field, rho_x = case$grids, update = update,
                               n_iter = 35000, burn_in = 15000, x_power = 1, seed = 1,
                               progress = FALSE)),
    griddy_message_memory = function(msg) {
      statement <<- trimws(conditionMessage(msg))
      invokeRestart("muffleMessage")
    }))
  fit <- m$value
  options(width = 10000)  # print()'s memory line on one line
  printed <- utils::capture.output(print(fit))
  n_grid <- nrow(fit$grid)
  run_order_bytes <- if (update == "thesis") 4 * n_runs * n_grid else 0
  stated_gb <- (8 * n_runs * n_grid + run_order_bytes + 8 * n_runs * n_points) / 1e9
  row <- data.frame(update = update, runs = n_runs, data_points = n_points,
                    grid_points = n_grid, info, up_front = statement,
                    print_memory = paste(trimws(grep("Memory", printed, value = TRUE)),
                                         collapse = " "),
                    stated_gb = stated_gb, elapsed_s = m$elapsed_s,
                    precompute_s = fit$runtime[["precompute"]],
                    sampling_s = fit$runtime[["sampling"]], cpu_s = m$cpu_s,
                    rss_before_mb = m$rss_before_mb, peak_extra_mb = m$peak_extra_mb,
                    peak_mb = m$peak_mb, machine_memory_gb = mem_total_gb(),
                    os_threads = m$os_threads, other_cores = m$other_cores,
                    load_1min = load_before)
  data.table::fwrite(row, out)
  quit(save = "no")
}

updates <- strsplit(Sys.getenv("BIG_UPDATES", "collapsed,thesis"), ",")[[1]]
start_note <- machine_note()
results <- data.table::rbindlist(lapply(updates, function(u) {
  cat(u, "...\n")
  out <- tempfile(fileext = ".csv")
  run_child("bench/big-grid-memory.R", c("--one", u, out), lib = new_griddy_lib())
  row <- data.table::fread(out)
  unlink(out)
  print(row[, .(update, elapsed_s, precompute_s, peak_mb, stated_gb)])
  row
}))
results[, machine := start_note]
results[, date := format(Sys.Date())]
dir.create("bench/results", showWarnings = FALSE, recursive = TRUE)
data.table::fwrite(results, "bench/results/big-grid-memory.csv")

shown <- results[, .(
  update, `calibrate() (s)` = signif(elapsed_s, 3), `precompute (s)` = signif(precompute_s, 3),
  `sampling (s)` = signif(sampling_s, 2), `CPU / elapsed` = round(cpu_s / elapsed_s, 2),
  `stated (GB)` = round(stated_gb, 2), `resident before (GB)` = round(rss_before_mb * 2^20 / 1e9, 2),
  `peak (GB)` = round(peak_mb * 2^20 / 1e9, 2),
  `peak above before (GB)` = round(peak_extra_mb * 2^20 / 1e9, 2),
  `machine (GB)` = round(machine_memory_gb, 1),
  threads = threads_label(threads_option, griddy_threads, os_threads), `other cores` = round(other_cores, 2), `load (1 min)` = load_1min)]
md <- c(
  md_header(paste(format(n_runs, big.mark = ",", scientific = FALSE),
                  "runs x 1,000 grid points: memory stated up front, and used"),
            "bench/big-grid-memory.R", start_note, results$load_1min, results$other_cores),
  "",
  paste0(format(n_runs, big.mark = ",", scientific = FALSE), " random runs x ", n_points,
         " data points with 3 coordinates as x; rho_x grid seq(0, 0.9, length.out = 10) per ",
         "coordinate (1,000 grid points), `x_power = 1`; 35,000 iterations; one process per update. ",
         "Stated: what the up-front statement adds up to (C, the thesis update's run order, the ",
         "library's outputs). Peak: the process's peak resident memory during calibrate() ",
         "(VmHWM), in all and above the memory before the call (the library was in memory ",
         "before). GB are 10^9 bytes, as the statement's."),
  "",
  md_table(shown),
  "",
  "What calibrate() said before computing C, and print(fit)'s memory line:",
  "",
  unlist(lapply(seq_len(nrow(results)), function(i) {
    said <- if (is.na(results$up_front[i])) "nothing (C is under 1 GB)" else
      paste0("\"", results$up_front[i], "\"")
    c(paste0("- ", results$update[i], ": ", said),
      paste0("  print(fit): \"", results$print_memory[i], "\""))
  }))
)
writeLines(md, "bench/results/big-grid-memory.md")
cat(md, sep = "\n")
