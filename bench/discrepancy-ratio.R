# A discrepancy fit against the plain fit (issue 36, items 2 and 4; bar 2),
# each pair timed in one process: calibrate() and calibrate(discrepancy =
# gp_discrepancy()) on the damped oscillation of gap-long-field.R (theta =
# (freq, damp) on a grid, 3 loads, a drift over t as the gap), rho_t = 0,
# 0.1, ..., 0.9, on three libraries:
#   long-1296: 36 x 36 runs, 480 field points (3 x 160 t): gap-long-field.R's
#   long-5041: 71 x 71 runs, 480 field points
#   short-5041: 71 x 71 runs, 60 field points (3 x 20 t)
# Each call REPEATS times (default 3), alternating plain and discrepancy;
# the median elapsed and CPU seconds (CPU: all threads of this process) and
# their ratios. The log Bayes factor of the discrepancy fit is printed as a
# check that before and after fit the same model.
#
# Run from the package root:  Rscript bench/discrepancy-ratio.R
# DISC_RATIO_SRC: "installed:<lib>" loads griddy from that library (default:
# pkgload::load_all(".")); DISC_RATIO_OUT: the results stem (default
# bench/results/discrepancy-ratio); REPEATS.
src <- Sys.getenv("DISC_RATIO_SRC", ".")
if (startsWith(src, "installed:")) {
  library(griddy, lib.loc = sub("installed:", "", src, fixed = TRUE))
} else {
  pkgload::load_all(src, quiet = TRUE)
}
source("bench/helpers.R")
out_stem <- Sys.getenv("DISC_RATIO_OUT", "bench/results/discrepancy-ratio")
repeats <- as.integer(Sys.getenv("REPEATS", "3"))

cases <- list(`long-1296` = c(36, 160), `long-5041` = c(71, 160), `short-5041` = c(71, 20))
timed <- function(expr) {
  t0 <- proc.time()
  value <- suppressWarnings(force(expr))
  used <- proc.time() - t0
  list(value = value, s = used[["elapsed"]], cpu = used[["user.self"]] + used[["sys.self"]])
}
rows <- list()
for (name in names(cases)) {
  sys <- damped_oscillation_system(cases[[name]][1], cases[[name]][2])
  args <- list(sys$lib, sys$field, rho_t = seq(0, 0.9, by = 0.1), seed = 1, progress = FALSE)
  plain <- disc <- list()
  for (r in seq_len(repeats)) {
    plain[[r]] <- timed(do.call(calibrate, args))
    disc[[r]] <- timed(do.call(calibrate, c(args, list(discrepancy = gp_discrepancy()))))
  }
  med <- function(runs, what) stats::median(vapply(runs, `[[`, 0, what))
  row <- data.frame(case = name, runs = cases[[name]][1]^2, field_points = 3 * cases[[name]][2],
                    grid_points = nrow(disc[[1]]$value$grid),
                    plain_s = med(plain, "s"), disc_s = med(disc, "s"),
                    plain_cpu = med(plain, "cpu"), disc_cpu = med(disc, "cpu"))
  row$ratio <- round(row$disc_s / row$plain_s, 1)
  row$cpu_ratio <- round(row$disc_cpu / row$plain_cpu, 1)
  row$log_bf <- signif(discrepancy_evidence(disc[[1]]$value)$log_bayes_factor, 8)
  print(row)
  rows[[name]] <- row
}
tab <- do.call(rbind, rows)
print(tab, row.names = FALSE)
utils::write.csv(tab, paste0(out_stem, ".csv"), row.names = FALSE)
writeLines(c(paste("griddy from:", src), paste("repeats:", repeats), machine_note()),
             paste0(out_stem, ".txt"))
