# SEPIA's ball drop 2 (examples/Ball_Drop/data/data_ball_drop_2 of the
# lanl/SEPIA repository, BSD-3) through griddy, for the like-for-like table
# of vignette("real-data-gap") beside SEPIA's own run
# (data-raw/sepia-reference.py, case ball_drop_2): four balls (x = radius R
# and density rho_ball) dropped from 20, 40 and 60 m; the simulator's 80
# runs are one 20-run design over the drag coefficient C and gravity g,
# repeated at each ball, timed at 101 heights. Read as
# ball_drop_2.ipynb reads them. read_calibration_inputs() makes them a
# library of 20 runs at the field's balls and heights; refine() without a
# simulator fills it in where the posterior is (runs predicted by a ppgasp
# emulator of the 20, its error in the likelihood), and the refined library
# is calibrated without and with a Kennedy-O'Hagan discrepancy
# (gp_discrepancy(orthogonal = FALSE), the quantity SEPIA reports). Times in ms (as
# data-raw/real-data-gap.R does for ball drop 1). Results:
# inst/extdata/ball_drop_2.rds. Run from the package root:
#   SEPIA_DIR=/path/to/SEPIA Rscript data-raw/ball-drop-2.R
pkgload::load_all(".", quiet = TRUE)
source("data-raw/sepia-files.R")  # sepia_dir, sepia_file()
numbers <- function(name) {
  as.matrix(utils::read.table(text = sepia_file(file.path(
    "examples/Ball_Drop/data/data_ball_drop_2", name)), comment.char = "#"))
}
set.seed(20261127)
ms <- 1000
field_raw <- numbers("fieldDat12x6gparam.txt")
balls <- stats::setNames(as.data.frame(numbers("desNative4x2Rrho.txt")), c("R", "rho"))
h_obs <- field_raw[1:3, 4]
y_obs <- matrix(field_raw[, 5], 4, 3, byrow = TRUE)
sim <- numbers("desNative80x4Cg.txt")
design <- stats::setNames(as.data.frame(sim), c("R", "rho", "C", "g"))
h_sim <- as.vector(numbers("simHeights101x1"))
y_sim <- t(numbers("sims101x80Cg.txt"))
expobs <- data.frame(balls, ms * y_obs)
timed <- function(expr) {
  start <- proc.time()[["elapsed"]]
  value <- force(expr)
  attr(value, "seconds") <- proc.time()[["elapsed"]] - start
  value
}
inputs <- suppressMessages(read_calibration_inputs(design, ms * y_sim, expobs, n_x = 2,
                                                   t = h_sim, t_field = h_obs, seed = 1))
# the 80 runs are 20 settings of (C, g) run at each of the four balls: a
# library of 20 runs (outputs interpolated to the field's heights), on which
# the posterior rests on a run or two; refine() without a simulator fills it
# in with runs predicted by a GP of the 20 (its error in the likelihood), and
# the discrepancy fit is made on that refined library
plain <- timed(suppressWarnings(calibrate(inputs$library, inputs$field, seed = 1)))
refined <- timed(suppressWarnings(refine(plain, max_runs = 4000, seed = 1)))
koh <- timed(suppressWarnings(calibrate(
  refined$library, inputs$field, seed = 1,
  discrepancy = gp_discrepancy(ratio = c(0, 10^seq(-1, 6, by = 0.5)), orthogonal = FALSE))))
table_of <- function(fit, method) {
  out <- lapply(c(0.9, 0.95), function(level) {
    s <- summary(fit, level = level)
    s <- s[s$parameter %in% c("C", "g"), ]
    data.frame(method = method, parameter = s$parameter, level = level, estimate = s$estimate,
               lower = s$lower, upper = s$upper)
  })
  cbind(do.call(rbind, out), seconds = attr(fit, "seconds"))
}
results <- list(
  made = format(Sys.time(), tz = "UTC", usetz = TRUE), session = R.version.string,
  table = rbind(table_of(plain, "griddy, 20-run library, no discrepancy"),
                table_of(refined, "griddy, refined library, no discrepancy"),
                table_of(koh, "griddy, refined library, gp_discrepancy(orthogonal = FALSE)")),
  loo_rms = inputs$library$loo_rms, runs = nrow(design),
  refinement = refined$refinement[c("runs_added", "rounds", "reason")])
saveRDS(results, "inst/extdata/ball_drop_2.rds", compress = "xz")
print(results$table, digits = 4)
