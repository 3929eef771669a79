# The gap on a long field (issue 36, items 2 and 4): a 1,296-run library of a
# small simulator of our own, 480 field points (3 settings x 160 times), a
# 10-point rho_t grid, one experiment with a gap. Times, in one process:
# calibrate(), calibrate(discrepancy = gp_discrepancy()) and diagnose_gap(fit)
# without candidates, and their ratios (bars: discrepancy fit / plain fit <= 2,
# diagnose_gap() / calibrate() <= 10).
#
# Run from the package root:  Rscript bench/gap-long-field.R
# GAP_LONG_SRC: the package to load (default "."; "installed:<lib>" loads
# griddy from that library instead, as for the before side); GAP_LONG_OUT:
# the results stem (default bench/results/gap-long-field); GAP_LONG_PARTS:
# which calls to time (default "plain,discrepancy,scaled,gap").
src <- Sys.getenv("GAP_LONG_SRC", ".")
if ("griddy" %in% loadedNamespaces()) {
  # already loaded (a profiling session that sources this file)
} else if (startsWith(src, "installed:")) {
  library(griddy, lib.loc = sub("installed:", "", src, fixed = TRUE))
} else {
  pkgload::load_all(src, quiet = TRUE)
}
source("bench/helpers.R")
out_stem <- Sys.getenv("GAP_LONG_OUT", "bench/results/gap-long-field")
parts <- strsplit(Sys.getenv("GAP_LONG_PARTS", "plain,discrepancy,scaled,gap"), ",")[[1]]

# the damped oscillation of bench/helpers.R (damped_oscillation_system()):
# 36 x 36 runs, 3 loads x 160 t, a drift over t as the gap
long_field_system <- function(n_t = 160, seed = 1) damped_oscillation_system(36, n_t, seed)

sys <- long_field_system()
rho_t <- seq(0, 0.9, by = 0.1)
timed <- function(expr) {
  t0 <- proc.time()
  value <- force(expr)
  used <- proc.time() - t0
  cat(deparse(substitute(expr))[1], ": ", format(used[["elapsed"]]), " s elapsed, ",
      format(used[["user.self"]] + used[["sys.self"]]), " s CPU\n", sep = "")
  list(value = value, s = used[["elapsed"]], cpu = used[["user.self"]] + used[["sys.self"]])
}
res <- list()
fit_args <- list(sys$lib, sys$field, rho_t = rho_t, seed = 1, progress = FALSE)
if ("plain" %in% parts) res$plain <- timed(do.call(calibrate, fit_args))
if ("discrepancy" %in% parts) {
  res$discrepancy <- timed(do.call(calibrate, c(fit_args, list(discrepancy = gp_discrepancy()))))
}
if ("scaled" %in% parts) {
  res$scaled <- timed(do.call(calibrate, c(fit_args,
                                           list(discrepancy = gp_discrepancy(scaled = TRUE)))))
}
if ("gap" %in% parts) {
  fit <- if (!is.null(res$plain)) res$plain$value else do.call(calibrate, fit_args)
  res$gap <- timed(diagnose_gap(fit, progress = FALSE))
}
secs <- vapply(res, `[[`, 0, "s")
cpu <- vapply(res, `[[`, 0, "cpu")
tab <- data.frame(call = names(secs), seconds = round(secs, 2), cpu_seconds = round(cpu, 2))
if (!is.null(res$plain)) {
  tab$over_plain <- round(secs / secs[["plain"]], 2)
  tab$cpu_over_plain <- round(cpu / cpu[["plain"]], 2)
}
print(tab)
if (!is.null(res$discrepancy)) {
  cat("log Bayes factor (discrepancy fit):",
      format(discrepancy_evidence(res$discrepancy$value)$log_bayes_factor, digits = 6), "\n")
}
utils::write.csv(tab, paste0(out_stem, ".csv"), row.names = FALSE)
writeLines(c(paste("griddy from:", src), machine_note()), paste0(out_stem, ".txt"))
