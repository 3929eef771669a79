# Issue 36, item 3: missing data at full-data speed. posterior_exact() (and
# calibrate()) on fields with missing cells against the same call on the
# full field, in one process, at MISSING_RUNS runs (default 10^5).
#
# Library: random runs of a two-parameter smooth response at 4 x settings x
# 40 output coordinates (160 outputs, 128 MB at 10^5 runs). Fields (the
# truth plus noise), each pattern with 10-30% of the cells missing:
# * full: every cell;
# * random: 20% of the cells missing at random;
# * setting: the second setting missing from t = 0.4 on (15% of the cells);
# * ragged: 25% missing at random, the others with 1-3 replicates each
#   (unequal replicates: cell means with relative sd and pure error);
# Noise models: independent (rho_x = rho_t = 0, one grid point) and a rho
# grid (rho_x in 0, 0.3, 0.6 x rho_t in 0, 0.5, 0.9: nine grid points).
# Each call is timed once, as the whole R call (elapsed), after a warm-up
# call on the full field; `ratio` is a pattern's time over the full field's
# in the same model and process.
#
# Usage, from the package root, with griddy installed (R CMD INSTALL .):
#   Rscript bench/missing-cells.R
# Options (environment): MISSING_RUNS (default 1e5), MISSING_PATTERNS
# (default "full,random,setting,ragged"), MISSING_CALIBRATE (default "1":
# also time calibrate()), MISSING_OUT (default "missing-cells": the file
# name under bench/results), GRIDDY_NEW_LIB (a library holding the griddy to
# test, e.g. the old code installed elsewhere).
source("bench/helpers.R")
if (nzchar(new_griddy_lib())) .libPaths(c(new_griddy_lib(), .libPaths()))
suppressPackageStartupMessages(library(griddy))
N <- as.numeric(Sys.getenv("MISSING_RUNS", "1e5"))
patterns <- strsplit(Sys.getenv("MISSING_PATTERNS", "full,random,setting,ragged"), ",")[[1]]
with_calibrate <- Sys.getenv("MISSING_CALIBRATE", "1") == "1"
out_name <- Sys.getenv("MISSING_OUT", "missing-cells")
load_before <- load_1min()

n_x <- 4
n_t <- 40
case <- settings_times_case(N, n_x, n_t, seed = 1)
tt <- case$t
xs <- case$x
response <- case$response
lib <- case$lib
rm(case)
truth <- matrix(response(0.4, 0.6), n_x, n_t, byrow = TRUE)

make_field <- function(pattern) {
  set.seed(2)
  y <- truth + rnorm(length(truth), sd = 0.05)
  if (pattern == "full") return(field_data(y, x = xs, t = tt))
  if (pattern == "random") {
    y[sample(length(y), round(0.2 * length(y)))] <- NA
    return(field_data(y, x = xs, t = tt))
  }
  if (pattern == "setting") {
    y[2, tt >= 0.4] <- NA
    return(field_data(y, x = xs, t = tt))
  }
  # ragged: long format, 1-3 replicates per measured cell
  long <- data.frame(x = rep(xs$x, each = n_t), t = rep(tt, n_x))
  long <- long[sort(sample(nrow(long), round(0.75 * nrow(long)))), ]
  long <- long[rep(seq_len(nrow(long)), sample(1:3, nrow(long), replace = TRUE)), ]
  long$y <- as.vector(response(0.4, 0.6))[match(paste(long$x, long$t),
                                                paste(rep(xs$x, each = n_t), rep(tt, n_x)))] +
    rnorm(nrow(long), sd = 0.05)
  field_data(long)
}

models <- list(independent = list(x = 0, t = 0),
               rho_grid = list(x = c(0, 0.3, 0.6), t = c(0, 0.5, 0.9)))
fields <- lapply(setNames(patterns, patterns), make_field)
missing_share <- c(full = 0, random = 0.2, setting = mean(tt >= 0.4) / n_x, ragged = 0.25)

elapsed <- function(expr) {
  t0 <- proc.time()[["elapsed"]]
  force(expr)
  proc.time()[["elapsed"]] - t0
}

# warm-up: the first call pays for loading and compiling
invisible(suppressWarnings(posterior_exact(lib, fields[[1]], joint = FALSE)))
rows <- list()
for (model in names(models)) {
  rho <- models[[model]]
  for (pattern in patterns) {
    exact_s <- elapsed(ex <- suppressWarnings(
      posterior_exact(lib, fields[[pattern]], rho_x = rho$x, rho_t = rho$t, joint = FALSE)))
    cal_s <- if (with_calibrate) elapsed(suppressWarnings(
      calibrate(lib, fields[[pattern]], rho_x = rho$x, rho_t = rho$t, seed = 1))) else NA
    rows[[length(rows) + 1L]] <- data.frame(
      runs = N, model = model, grid_points = nrow(ex$grid), pattern = pattern,
      missing = unname(missing_share[pattern]), posterior_exact_s = exact_s,
      calibrate_s = cal_s, log_evidence = ex$log_evidence,
      griddy = as.character(utils::packageVersion("griddy")),
      lib = if (nzchar(new_griddy_lib())) new_griddy_lib() else "default",
      machine = machine_note())
    print(rows[[length(rows)]][, 1:8])
    gc()
  }
}
out <- do.call(rbind, rows)
full <- out[out$pattern == "full", ]
out$exact_ratio <- out$posterior_exact_s / full$posterior_exact_s[match(out$model, full$model)]
out$calibrate_ratio <- out$calibrate_s / full$calibrate_s[match(out$model, full$model)]
dir.create("bench/results", showWarnings = FALSE)
write.csv(out, file.path("bench/results", paste0(out_name, ".csv")), row.names = FALSE)
fmt <- function(v, d = 3) format(signif(v, d), scientific = FALSE, trim = TRUE)
md <- c(paste0("# Missing cells against the full field (issue 36, item 3): ", out_name), "",
        paste0("`Rscript bench/missing-cells.R`; ", format(N, big.mark = ",", scientific = FALSE),
               " runs x ", n_x * n_t, " outputs; ", machine_note(), " (1-min load before: ",
               format(load_before), "). One process; ratio = time / the full field's in the ",
               "same model."), "",
        "| model | G | pattern | missing | posterior_exact (s) | ratio | calibrate (s) | ratio |",
        "|---|---|---|---|---|---|---|---|",
        sprintf("| %s | %d | %s | %s | %s | %s | %s | %s |", out$model, out$grid_points,
                out$pattern, fmt(out$missing, 2), fmt(out$posterior_exact_s),
                fmt(out$exact_ratio, 2), fmt(out$calibrate_s), fmt(out$calibrate_ratio, 2)))
writeLines(md, file.path("bench/results", paste0(out_name, ".md")))
writeLines(md)
