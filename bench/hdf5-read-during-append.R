# Issue 32 item 3: readers never blocked by a writer. A library of N runs
# (default 10^6) x 5 outputs is written to an HDF5 file; then a writer in a
# second R process appends pieces of 5,000 new runs for `GRIDDY_BENCH_SECONDS`
# (default 60) while this process, the reader, opens the library and
# calibrates from it again and again. Before (HDF5 files opened without SWMR)
# readers were refused while an append held the file: 39 of 40 reads in 60 s
# during a campaign. Each read records whether it succeeded, how long it took
# and how many runs it saw, which must be a committed count (N + k * 5,000,
# k appends finished) and match the outputs it read (the last run's).
#
# Usage, from the package root, with griddy installed (with hdf5r):
#   Rscript bench/hdf5-read-during-append.R
# or on the source tree, GRIDDY_BENCH_SOURCE=1 Rscript bench/hdf5-read-during-append.R
# (loads it with pkgload). GRIDDY_BENCH_N and GRIDDY_BENCH_SECONDS change the
# size and the length of the campaign.
# Writes bench/results/hdf5-read-during-append.csv (one row per read),
# bench/results/hdf5-read-during-append-appends.csv (one row per append) and
# bench/results/hdf5-read-during-append.md (the summary), and prints it.
source("bench/helpers.R")
args <- commandArgs(TRUE)
N <- as.numeric(Sys.getenv("GRIDDY_BENCH_N", 1e6))
seconds <- as.numeric(Sys.getenv("GRIDDY_BENCH_SECONDS", 60))
piece <- 5000
t_out <- 1:5

load_griddy <- function() {
  if (nzchar(Sys.getenv("GRIDDY_BENCH_SOURCE"))) {
    suppressMessages(pkgload::load_all(".", quiet = TRUE, export_all = FALSE))
  } else {
    suppressPackageStartupMessages(library(griddy))
  }
}

# Runs first..last: two parameters from a fixed stream, outputs a * t + b * t^2.
run_theta <- function(i) data.frame(a = (i * 0.6180339887) %% 1, b = (i * 0.7548776662) %% 1)
run_y <- function(theta) outer(theta$a, t_out) + outer(theta$b, t_out^2)
runs <- function(first, last) {
  theta <- run_theta(seq.int(first, last))
  sim_library(theta, run_y(theta), t = t_out)
}

if (length(args) == 3 && args[1] == "--writer") {
  load_griddy()
  file <- args[2]
  log <- args[3]
  stop_at <- Sys.time() + seconds
  n <- hdf5_library(file)$n_runs
  cat("start,end,n_runs\n", file = log)
  while (Sys.time() < stop_at) {
    start <- Sys.time()
    write_library(runs(n + 1, n + piece), file, append = TRUE)
    n <- n + piece
    cat(format(as.numeric(start), nsmall = 3), ",", format(as.numeric(Sys.time()), nsmall = 3),
        ",", n, "\n", sep = "", file = log, append = TRUE)
  }
  quit(save = "no")
}

load_griddy()
dir <- tempfile("read-during-append-")
dir.create(dir)
file <- file.path(dir, "library.h5")
t_write <- time_it(write_library(runs(1, N), file))
cat("wrote", N, "runs in", round(t_write, 1), "s:", format(file.size(file) / 1e6, digits = 3),
    "MB\n")
truth <- c(a = 0.3, b = 0.6)
set.seed(1)
field <- field_data(truth[["a"]] * t_out + truth[["b"]] * t_out^2 + rnorm(5, sd = 0.05))

appends_log <- file.path(dir, "appends.csv")
script <- normalizePath("bench/hdf5-read-during-append.R")
system2(file.path(R.home("bin"), "Rscript"), c(shQuote(script), "--writer", shQuote(file),
                                               shQuote(appends_log)),
        wait = FALSE, env = paste0("GRIDDY_BENCH_SECONDS=", seconds))
while (!file.exists(appends_log)) Sys.sleep(0.1)
start <- Sys.time()
reads <- list()
while (as.numeric(difftime(Sys.time(), start, units = "secs")) < seconds + 5) {
  t0 <- Sys.time()
  out <- tryCatch({
    lib <- hdf5_library(file)
    last <- griddy:::lib_outputs(lib, lib$n_runs)
    fit <- suppressWarnings(calibrate(lib, field, n_iter = 200, burn_in = 50, seed = 1))
    list(ok = TRUE, n_runs = lib$n_runs,
         consistent = (lib$n_runs - N) %% piece == 0 &&
           isTRUE(all.equal(as.vector(last), as.vector(run_y(run_theta(lib$n_runs))))),
         error = "")
  }, error = function(e) list(ok = FALSE, n_runs = NA, consistent = NA,
                              error = conditionMessage(e)))
  reads[[length(reads) + 1L]] <- data.frame(
    start = as.numeric(difftime(t0, start, units = "secs")),
    seconds = as.numeric(difftime(Sys.time(), t0, units = "secs")), ok = out$ok,
    n_runs = out$n_runs, consistent = out$consistent, error = substr(out$error, 1, 200))
}
Sys.sleep(2)
reads <- do.call(rbind, reads)
appends <- utils::read.csv(appends_log)
appends$seconds <- appends$end - appends$start
dir.create("bench/results", showWarnings = FALSE)
utils::write.csv(reads, "bench/results/hdf5-read-during-append.csv", row.names = FALSE)
utils::write.csv(appends, "bench/results/hdf5-read-during-append-appends.csv", row.names = FALSE)
summary <- c(
  "# Reading an HDF5 library while another process appends (issue 32, item 3)",
  "",
  paste0("Library: ", format(N, big.mark = ",", scientific = FALSE), " runs x 5 outputs, 2 parameters (",
         format(file.size(file) / 1e6, digits = 3), " MB after the campaign); written in ",
         round(t_write, 1), " s. Writer: appends of ", format(piece, big.mark = ","),
         " new runs for ", seconds, " s in a second R process. Reader: hdf5_library() + ",
         "calibrate(n_iter = 200) in a loop."),
  "",
  "| | value |", "|---|---|",
  paste0("| reads | ", nrow(reads), " |"),
  paste0("| reads refused or failed | ", sum(!reads$ok), " |"),
  paste0("| reads that saw a committed prefix (count and last run's outputs) | ",
         sum(reads$consistent, na.rm = TRUE), " of ", sum(reads$ok), " |"),
  paste0("| distinct run counts seen | ", length(unique(stats::na.omit(reads$n_runs))), " |"),
  paste0("| read + calibration time, median (s) | ",
         round(stats::median(reads$seconds[reads$ok]), 2), " |"),
  paste0("| appends finished | ", nrow(appends), " |"),
  paste0("| append time, median / max (s) | ", round(stats::median(appends$seconds), 2), " / ",
         round(max(appends$seconds), 2), " |"),
  "", machine_note())
writeLines(summary, "bench/results/hdf5-read-during-append.md")
writeLines(summary)
unlink(dir, recursive = TRUE)
