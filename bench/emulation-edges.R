# The spot-weld data (Bayarri et al. 2007, from the archived CRAN package
# SAVE, as bench/published-data.R reads them) through an emulated library:
# where the posterior of `tuning` sits with the emulator's error in the
# likelihood, and without it (issue 22: 54% of it sat on the design's upper
# edge). Prints calibrate()'s summary, the exact posterior's mass in the top
# 5% of tuning's range, any warnings, and the fit without the error term.
#
# Run from the package root: Rscript bench/emulation-edges.R [path]
# (path: the package source to load, default ".").
args <- commandArgs(TRUE)
pkgload::load_all(if (length(args)) args[1] else ".", quiet = TRUE)
source("bench/helpers.R")  # load_save(): the SAVE package's published data
model <- load_save("spotweldmodel")
field <- load_save("spotweldfield")
x <- c("load", "current", "thickness")
inputs <- suppressMessages(read_calibration_inputs(design = model[c(x, "tuning")],
                                                   simobs = model["diameter"],
                                                   expobs = field[c(x, "diameter")], n_x = 3))
lib <- inputs$library
say <- function(w) {
  cat("warning (", class(w)[1], "): ", conditionMessage(w), "\n", sep = "")
  invokeRestart("muffleWarning")
}
fit <- withCallingHandlers(calibrate(lib, inputs$field, seed = 1), warning = say)
print(summary(fit))
tuning <- lib$theta$tuning
p <- grid_posterior(fit)$run
top <- tuning > stats::quantile(tuning, 0.95)
cat("mass in the top 5% of tuning's range:", signif(sum(p[top]), 3), "\n")
cat("\nWithout the error term:\n")
plain <- lib
plain$error <- NULL
print(summary(suppressWarnings(calibrate(plain, inputs$field, seed = 1))))
