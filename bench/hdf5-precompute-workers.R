# Issue 26 item 4: the misfit table's precompute of an HDF5 library, chunk
# by chunk, on the future plan's workers. An HDF5 library of N runs x 54
# outputs is written once; then calibrate() (n_iter small: the precompute is
# what is timed, fit$runtime[["precompute"]]) runs from it with an AR(1)
# grid of G rho_t points, in a fresh R process per mode:
#   sequential-1thread  plan(sequential), options(griddy.threads = 1)
#   sequential          plan(sequential), griddy's default threads
#   multisession-2      plan(multisession, workers = 2): each worker reads
#                       and computes its chunks (one thread each)
# `repeats` calls per mode; C must be identical in every mode.
#
# Usage, from the package root after installing griddy (with hdf5r and
# future.apply), e.g. into a private library:
#   R CMD INSTALL -l /tmp/lib . && R_LIBS=/tmp/lib Rscript bench/hdf5-precompute-workers.R
# GRIDDY_BENCH_N (default 2e5) and GRIDDY_BENCH_G (grid sizes, default "8,64")
# change the size.
# Writes bench/results/hdf5-precompute-workers.csv and prints the table.
source("bench/helpers.R")
args <- commandArgs(TRUE)
N <- as.numeric(Sys.getenv("GRIDDY_BENCH_N", 2e5))
G_values <- as.integer(strsplit(Sys.getenv("GRIDDY_BENCH_G", "8,64"), ",")[[1]])
n <- 54
chunk <- N / 8
repeats <- 3L

if (length(args) == 4 && args[1] == "--precompute") {
  suppressPackageStartupMessages(library(griddy))
  dir <- args[2]
  mode <- args[3]
  G <- as.integer(args[4])
  if (mode == "sequential-1thread") options(griddy.threads = 1L)
  # workers start (and load griddy) before the timed calls: `workers_s`
  t_workers <- time_it(if (mode == "multisession-2") {
    future::plan(future::multisession, workers = 2)
    future.apply::future_lapply(1:2, function(i) requireNamespace("griddy"))
  } else {
    future::plan(future::sequential)
  })
  griddy_workers_here <- get("griddy_workers", asNamespace("griddy"))
  lib <- hdf5_library(file.path(dir, "library.h5"), chunk_size = chunk)
  field <- field_data(thesis_field(n), t = seq(0, 1, length.out = n))
  rho_t <- seq(0.1, 0.8, length.out = G)
  times <- numeric(repeats)
  for (r in seq_len(repeats)) {
    fit <- suppressWarnings(calibrate(lib, field, rho_t = rho_t, n_iter = 200, burn_in = 100,
                                      seed = 1, progress = FALSE))
    times[r] <- fit$runtime[["precompute"]]
  }
  saveRDS(fit$C, file.path(dir, paste0("C-", mode, ".rds")))
  # the C++ threads of each process that computes (griddy's choice)
  threads <- get("threads_per_worker", asNamespace("griddy"))(griddy_workers_here())
  data.table::fwrite(data.frame(mode = mode, grid_points = G, workers_s = t_workers,
                                threads = threads,
                                repeat_ = seq_len(repeats), precompute_s = times,
                                machine = machine_note()))
  quit(save = "no")
}

suppressPackageStartupMessages(library(griddy))
dir <- file.path(tempdir(), "griddy-precompute-workers")
unlink(dir, recursive = TRUE)
dir.create(dir, recursive = TRUE)
t_write <- write_thesis_hdf5(dir, N, n, chunk)

rscript <- file.path(R.home("bin"), "Rscript")
modes <- c("sequential-1thread", "sequential", "multisession-2")
results <- data.table::rbindlist(lapply(G_values, function(G) {
  res <- data.table::rbindlist(lapply(modes, function(m) {
    data.table::fread(text = system2(rscript, c("bench/hdf5-precompute-workers.R", "--precompute",
                                                dir, m, G), stdout = TRUE))
  }))
  C <- lapply(modes, function(m) readRDS(file.path(dir, paste0("C-", m, ".rds"))))
  res[, C_identical := all(vapply(C[-1], identical, logical(1), C[[1]]))]
}))
results[, `:=`(runs = N, outputs = n, chunks = N / chunk, write_s = t_write,
               date = format(Sys.Date()))]
dir.create("bench/results", showWarnings = FALSE)
data.table::fwrite(results, "bench/results/hdf5-precompute-workers.csv")
print(results[, .(median_s = median(precompute_s), min_s = min(precompute_s),
                  max_s = max(precompute_s), workers_s = workers_s[1], threads = threads[1],
                  C_identical = C_identical[1]), by = .(grid_points, mode)])
cat(results$machine[1], "\n")
unlink(dir, recursive = TRUE)
