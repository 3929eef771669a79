# A library larger than memory, in miniature: 10^6 runs x 54 outputs (432 MB)
# written to an HDF5 file with write_library() in 10 appends of 10^5 runs,
# piece by piece (the whole library is never in memory while writing), then
# calibrated from disk with hdf5_library() reading 10 chunks of 10^5 runs,
# mapped by future.apply under plan(sequential) and
# plan(multisession, workers = 2), and, for comparison, from memory. Each
# calibration runs in a fresh R process, so `peak_mb` (VmHWM) is its own;
# the disk runs' main process holds C (8 MB here) and the parameter values,
# each worker one chunk at a time. C and the draws must be identical in all
# three modes. 35,000 iterations (burn-in 15,000), collapsed and thesis
# updates.
#
# Usage, from the package root after installing griddy (with hdf5r):
#   Rscript bench/disk-library.R [directory, default a temporary one]
# Writes bench/results/disk-library.csv and prints the table.
source("bench/helpers.R")
args <- commandArgs(TRUE)
N <- as.numeric(Sys.getenv("GRIDDY_BENCH_N", 1e6))  # smaller for a smoke test
n <- 54
chunk <- N / 10

if (length(args) == 3 && args[1] == "--calibrate") {
  suppressPackageStartupMessages(library(griddy))
  dir <- args[2]
  mode <- args[3]
  base <- peak_mb()
  t_open <- time_it({
    lib <- if (mode == "memory") {
      d <- hdf5_library(file.path(dir, "library.h5"), chunk_size = chunk)
      # all outputs through the library interface (internal to griddy)
      y <- eval(quote(lib_outputs(d)), list(d = d), asNamespace("griddy"))
      sim_library(d$theta, y, t = d$t)
    } else {
      hdf5_library(file.path(dir, "library.h5"), chunk_size = chunk)
    }
  })
  # workers start (and load griddy) before the timed calls: `workers_s`
  t_workers <- time_it(if (mode == "multisession") {
    future::plan(future::multisession, workers = 2)
    future.apply::future_lapply(1:2, function(i) requireNamespace("griddy"))
  })
  if (mode == "sequential") future::plan(future::sequential)
  field <- field_data(thesis_field(n))
  fits <- lapply(c(collapsed = "collapsed", thesis = "thesis"), function(u) {
    suppressWarnings(calibrate(lib, field, n_iter = 35000, burn_in = 15000, update = u,
                               seed = 1))
  })
  saveRDS(list(C = fits$collapsed$C, draws = lapply(fits, `[[`, "draws")),
          file.path(dir, paste0("result-", mode, ".rds")))
  data.table::fwrite(data.frame(
    mode = mode, open_s = t_open, workers_s = t_workers,
    collapsed_precompute_s = fits$collapsed$runtime[["precompute"]],
    collapsed_sampling_s = fits$collapsed$runtime[["sampling"]],
    thesis_precompute_s = fits$thesis$runtime[["precompute"]],
    thesis_sampling_s = fits$thesis$runtime[["sampling"]],
    base_mb = base, peak_mb = peak_mb()))
  quit(save = "no")
}

suppressPackageStartupMessages(library(griddy))
dir <- if (length(args) >= 1) args[1] else file.path(tempdir(), "griddy-1e6")
unlink(dir, recursive = TRUE)
dir.create(dir, recursive = TRUE)
t_write <- write_thesis_hdf5(dir, N, n, chunk)
write_peak <- peak_mb()
disk_mb <- file.size(file.path(dir, "library.h5")) / 2^20

rscript <- file.path(R.home("bin"), "Rscript")
modes <- c("sequential", "multisession", "memory")
results <- data.table::rbindlist(lapply(modes, function(m) {
  res <- data.table::fread(text = system2(rscript, c("bench/disk-library.R", "--calibrate",
                                                      dir, m), stdout = TRUE))
  print(res, digits = 3)
  res
}))
out <- lapply(modes, function(m) readRDS(file.path(dir, paste0("result-", m, ".rds"))))
results[, `:=`(runs = N, data_points = n, chunks = N / chunk,
               library_mb = 8 * N * n / 2^20, disk_mb = disk_mb,
               C_identical_to_memory = vapply(out, function(o) identical(o$C, out[[3]]$C), TRUE),
               draws_identical_to_memory = vapply(out, function(o) identical(o$draws, out[[3]]$draws), TRUE),
               write_s = t_write, write_peak_mb = write_peak,
               machine = machine_note(), date = format(Sys.Date()))]
print(results[, .(mode, open_s, collapsed_precompute_s, collapsed_sampling_s, thesis_precompute_s,
                  thesis_sampling_s, peak_mb, library_mb, C_identical_to_memory,
                  draws_identical_to_memory)], digits = 3)
cat("written in", round(t_write, 1), "s; on disk", round(disk_mb), "MB\n")
dir.create("bench/results", showWarnings = FALSE, recursive = TRUE)
data.table::fwrite(results, "bench/results/disk-library.csv")
unlink(dir, recursive = TRUE)
