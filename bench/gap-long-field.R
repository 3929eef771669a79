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

# a damped oscillation whose amplitude grows with the load; theta = (freq,
# damp); reality adds a slow drift over t that grows with the load (the gap)
long_field_system <- function(n_t = 160, seed = 1) {
  set.seed(seed)
  x <- data.frame(load = c(1, 2, 3))
  t <- seq(0, 1, length.out = n_t)
  sim <- function(freq, damp, drift = 0) {
    out <- matrix(0, length(freq), nrow(x) * n_t)
    for (k in seq_len(nrow(x))) {
      l <- x$load[k]
      out[, (k - 1) * n_t + seq_len(n_t)] <- l * exp(-outer(damp, t)) * sin(outer(freq, t)) +
        drift * l * outer(rep(1, length(freq)), t^2)
    }
    out
  }
  theta <- expand.grid(freq = seq(4, 8, length.out = 36), damp = seq(0.5, 2.5, length.out = 36))
  lib <- sim_library(theta, sim(theta$freq, theta$damp), x = x, t = t)
  y <- drop(sim(6.03, 1.47, drift = 0.15)) + rnorm(nrow(x) * n_t, sd = 0.05)
  field <- field_data(matrix(y, nrow(x), byrow = TRUE), x = x, t = t)
  list(lib = lib, field = field)
}

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
