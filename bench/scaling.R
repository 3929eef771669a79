# Scaling of calibrate(): N from 10^3 to 10^6 runs (n = 54, G = 1), n from 50
# to 1,500 data points (N = 10^4), G from 1 to 1,000 correlation grid points
# (rho_t, N = 10^4, n = 54); 35,000 iterations (burn-in 15,000), one chain.
# Precompute (C, and its sorting / truncated CDFs) and sampling are timed
# separately, for both updates. Each configuration runs in a fresh R process;
# before each calibrate() call the process's peak resident memory is reset
# (/proc/self/clear_refs), so `*_extra_mb` is the peak during the call above
# the resident memory before it (`rss_before_mb`, library included):
# memory calibrate() allocated. Compare with `library_mb`, the library's
# outputs (8 N n bytes), and `C_mb`, the table of C (8 N G bytes). The physical
# limit for reference, `memory_pass_s`, is the time of one pass over the
# library in memory (sum(y)).
#
# Usage, from the package root after installing griddy:
#   Rscript bench/scaling.R
# Writes bench/results/scaling.csv and prints the table.
source("bench/helpers.R")
args <- commandArgs(TRUE)

if (length(args) == 4 && args[1] == "--one") {
  suppressPackageStartupMessages(library(griddy))
  N <- as.numeric(args[2]); n <- as.numeric(args[3]); G <- as.numeric(args[4])
  runs <- thesis_runs(N, n)
  lib <- sim_library(runs$theta, runs$y, t = runs$t)
  rm(runs)
  field <- field_data(thesis_field(n))
  reps <- max(3, ceiling(1e8 / (N * n)))  # enough passes to time well
  pass <- time_it(for (r in seq_len(reps)) sum(lib$y)) / reps
  rho_t <- if (G == 1) 0 else seq(0, 0.95, length.out = G)
  fits <- lapply(c("collapsed", "thesis"), function(u) {
    gc()
    reset_peak()
    before <- rss_mb()
    fit <- suppressWarnings(calibrate(lib, field, rho_t = rho_t, n_iter = 35000,
                                      burn_in = 15000, update = u, seed = 1))
    c(fit$runtime, head = mean(fit$head_length), before = before, peak = peak_mb())
  })
  out <- data.frame(runs = N, data_points = n, grid_points = G,
                    memory_pass_s = pass,
                    collapsed_precompute_s = fits[[1]][["precompute"]],
                    collapsed_sampling_s = fits[[1]][["sampling"]],
                    collapsed_head_runs = fits[[1]][["head"]],
                    thesis_precompute_s = fits[[2]][["precompute"]],
                    thesis_sampling_s = fits[[2]][["sampling"]],
                    thesis_head_runs = fits[[2]][["head"]],
                    library_mb = 8 * N * n / 2^20, C_mb = 8 * N * G / 2^20,
                    rss_before_mb = fits[[1]][["before"]],
                    collapsed_extra_mb = fits[[1]][["peak"]] - fits[[1]][["before"]],
                    thesis_extra_mb = fits[[2]][["peak"]] - fits[[2]][["before"]])
  data.table::fwrite(out)
  quit(save = "no")
}

configs <- rbind(
  data.frame(N = c(1e3, 1e4, 1e5, 1e6), n = 54, G = 1),
  data.frame(N = 1e4, n = c(50, 150, 500, 1500), G = 1),
  data.frame(N = 1e4, n = 54, G = c(10, 100, 1000))
)
rscript <- file.path(R.home("bin"), "Rscript")
rows <- lapply(seq_len(nrow(configs)), function(k) {
  cfg <- configs[k, ]
  out <- system2(rscript, c("bench/scaling.R", "--one", format(cfg$N, scientific = FALSE),
                            cfg$n, cfg$G), stdout = TRUE)
  res <- data.table::fread(text = out)
  print(res, digits = 3)
  res
})
results <- data.table::rbindlist(rows)
results[, machine := machine_note()]
results[, date := format(Sys.Date())]
print(results[, .(runs, data_points, grid_points, memory_pass_s, collapsed_precompute_s,
                  collapsed_sampling_s, thesis_precompute_s, thesis_sampling_s,
                  thesis_head_runs, library_mb, C_mb, rss_before_mb, collapsed_extra_mb,
                  thesis_extra_mb)], digits = 3)
dir.create("bench/results", showWarnings = FALSE, recursive = TRUE)
data.table::fwrite(results, "bench/results/scaling.csv")
