# The emulation check on 50-run joint designs (issue 22): 30 trials of the
# toy of tests/testthat/helper-emulated.R (y = exp(-c t) sin(k t + x), a
# Latin hypercube of 50 runs over (x, k, c)), each with its own design and a
# truth drawn in the middle 80% of the box, field noise sd 0.05 at three
# settings; calibrate() then refine() without a simulator. Counts the fits
# whose 95% interval misses the truth of k or c, and the trials with a
# warning of class griddy_warning_emulation.
#
# Run from the package root: Rscript bench/emulation-check.R [path]
# (path: the package source to load, default "."). EMUL_RUNS (default 50)
# sets the design's size and EMUL_SD (default 0.05) the field noise sd: a
# design of 15 runs gives an emulator far worse than the noise.
args <- commandArgs(TRUE)
n_design <- as.integer(Sys.getenv("EMUL_RUNS", "50"))
noise_sd <- as.numeric(Sys.getenv("EMUL_SD", "0.05"))
pkgload::load_all(if (length(args)) args[1] else ".", quiet = TRUE)
source("tests/testthat/helper-emulated.R")
rows <- lapply(1:30, function(trial) {
  lib <- suppressMessages(emulated_toy_library(n = n_design, n_runs = 2000, seed = trial))
  set.seed(100 + trial)
  truth <- c(k = stats::runif(1, 1.2, 2.8), c = stats::runif(1, 0.14, 0.46))
  field <- emulated_toy_field(k = truth[["k"]], c = truth[["c"]], sd = noise_sd, seed = 200 + trial)
  warned <- FALSE
  muffle <- function(w) {
    if (inherits(w, "griddy_warning_emulation")) warned <<- TRUE
    invokeRestart("muffleWarning")
  }
  ref <- withCallingHandlers({
    fit <- calibrate(lib, field, seed = trial)
    suppressMessages(refine(fit, seed = trial))
  }, warning = muffle)
  s <- summary(ref)
  s <- s[match(c("k", "c"), s$parameter), ]
  covered <- s$lower <= truth & truth <= s$upper
  data.frame(trial = trial, k = truth[["k"]], c = truth[["c"]], miss = !all(covered),
             warned = warned, ratio = if (is.null(ref$refinement)) ref$emulation_error else
               ref$refinement$emulation_error)
})
out <- do.call(rbind, rows)
print(out, digits = 3)
cat(sprintf("misses %d of %d; warned %d; misses with a warning %d\n", sum(out$miss), nrow(out),
            sum(out$warned), sum(out$miss & out$warned)))
