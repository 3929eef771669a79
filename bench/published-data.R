# Published calibration data sets through griddy as they come (issue 13):
#   spot weld   Bayarri et al. (2007): 35 runs of a spot-weld FE model over
#               (load, current, thickness, tuning) jointly, the nugget
#               diameter; 120 field welds, 5 replicates at 24 settings;
#   synthetic   the SAVE package's synthetic example: 15 runs over (x, v),
#               30 field values, 3 replicates at 10 settings.
# Both ship with the CRAN package SAVE (archived; its data are read from the
# archive's tarball, not installed). Each goes through
# read_calibration_inputs() -> calibrate() -> refine() and, for comparison,
# koh_calibrate() without a discrepancy (RobustCalibration), on the same
# inputs.
#
# Run from the package root with griddy installed:
#   Rscript bench/published-data.R
# Writes bench/results/published-data.md.

library(griddy)
out_md <- "bench/results/published-data.md"
source("bench/helpers.R")  # load_save(): the SAVE package's published data

studies <- list(
  spot_weld = list(model = load_save("spotweldmodel"), field = load_save("spotweldfield"),
                   x = c("load", "current", "thickness"), theta = "tuning", y = "diameter"),
  synthetic = list(model = load_save("synthmodel"), field = load_save("synthfield"),
                   x = "x", theta = "v", y = "y")
)

lines <- c("# Published data sets (bench/published-data.R)", "",
           paste0("griddy ", packageVersion("griddy"), ", ", format(Sys.time(), "%Y-%m-%d"), ", ",
                  R.version.string), "")
for (name in names(studies)) {
  s <- studies[[name]]
  timed <- function(expr) {
    start <- proc.time()[["elapsed"]]
    value <- force(expr)
    list(value = value, seconds = proc.time()[["elapsed"]] - start)
  }
  inputs <- timed(read_calibration_inputs(design = s$model[c(s$x, s$theta)],
                                          simobs = s$model[s$y],
                                          expobs = s$field[c(s$x, s$y)], n_x = length(s$x)))
  fit <- timed(calibrate(inputs$value$library, inputs$value$field, seed = 1))
  refined <- timed(refine(fit$value, seed = 1))
  lines <- c(lines, paste0("## ", name), "", "```",
             utils::capture.output(print(inputs$value$library)),
             utils::capture.output(print(summary(refined$value))), "```", "",
             sprintf("read %.1f s, calibrate %.1f s, refine %.1f s", inputs$seconds,
                     fit$seconds, refined$seconds), "")
  if (requireNamespace("RobustCalibration", quietly = TRUE)) {
    koh <- tryCatch(timed(koh_calibrate(inputs$value$library, inputs$value$field,
                                        discrepancy = "none", n_iter = 20000, burn_in = 5000,
                                        seed = 1)),
                    griddy_error_unsupported = function(e) conditionMessage(e))
    lines <- c(lines, "KOH without discrepancy (koh_calibrate):", "",
               if (is.character(koh)) paste("Not run:", koh) else
                 c("```", utils::capture.output(print(summary(koh$value))), "```", "",
                   sprintf("koh_calibrate %.1f s", koh$seconds)), "")
  }
}
writeLines(lines, out_md)
cat(lines, sep = "\n")
