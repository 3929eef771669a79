# The vignette "Real data: is there a gap?" (vignettes/real-data-gap.Rmd):
# SEPIA's ball drop 1 through the whole path. SEPIA (Los Alamos, BSD-3; the
# lanl/SEPIA repository) publishes it in examples/Ball_Drop/data:
#   sim.design   25 runs, a Latin hypercube over the radius R and the drag
#                coefficient C jointly;
#   sim.dat      their fall times at 16 heights (one column per run);
#   sim.height   the heights 1.5, 3, ..., 24 m;
#   field.dat    three balls (field.radii: R = 0.1, 0.2, 0.4 m) timed at the
#                heights in field.height (5, 10, 15, 20 m), between the
#                simulator's.
# The simulator has linear drag, the field data come from quadratic drag
# (see inst/extdata/real_data_gap_physics.R), so there is a gap to find.
#
# This script copies the data into inst/extdata/real_data_gap_*.csv (with
# SEPIA's licence in real_data_gap_NOTICE.txt) and computes what the
# vignette reports: the fits with and without a discrepancy, the gap
# diagnosis with two physical candidates, and the fit with the winning one,
# into inst/extdata/real_data_gap.rds; each discrepancy fit both ways, with
# the orthogonal default (the best-fitting theta) and with orthogonal = FALSE
# (Kennedy and O'Hagan's theta, which SEPIA and RobustCalibration report).
# About two minutes. The comparison with SEPIA and RobustCalibration at
# their 90% level comes from bench/published-discrepancy.R
# (inst/extdata/published_discrepancy.csv).
#
# Run from the package root with a copy of SEPIA's repository (a checkout, or
# a bare git directory) at SEPIA_DIR:
#   SEPIA_DIR=/path/to/SEPIA Rscript data-raw/real-data-gap.R
pkgload::load_all(".", quiet = TRUE)
source("inst/extdata/real_data_gap_physics.R")
set.seed(20261125)
out_dir <- "inst/extdata"

# ---- SEPIA's files, as published -------------------------------------------------
source("data-raw/sepia-ball-drop.R")  # design, h_sim, h_field, radii, expobs, numbers()
simobs <- t(numbers("sim.dat"))  # one row per run
colnames(simobs) <- paste0("h", h_sim)
names(expobs)[-1] <- paste0("h", h_field)
write_csv <- function(d, file) {
  utils::write.csv(signif(d, 10), file.path(out_dir, file), row.names = FALSE)
}
write_csv(design, "real_data_gap_design.csv")
write_csv(as.data.frame(simobs), "real_data_gap_simobs.csv")
write_csv(expobs, "real_data_gap_expobs.csv")
notice <- c("real_data_gap_design.csv, real_data_gap_simobs.csv and real_data_gap_expobs.csv",
            "hold SEPIA's ball drop 1 data (examples/Ball_Drop/data of the lanl/SEPIA",
            "repository: sim.design, sim.dat (transposed: one row per run), sim.height",
            "(the simobs column names), field.radii, field.height and field.dat), under",
            "SEPIA's licence:", "", sepia_file("License-BSD-3"))
writeLines(notice, file.path(out_dir, "real_data_gap_NOTICE.txt"))

# ---- the whole path ----------------------------------------------------------------
timed <- function(expr) {
  start <- proc.time()[["elapsed"]]
  value <- force(expr)
  attr(value, "seconds") <- proc.time()[["elapsed"]] - start
  value
}
# in seconds the misfits are so small (a few ms squared) that the default
# Gamma prior's rate on tau would not be negligible: calibrate in ms
ms <- 1000
# the noise is a few ms and the gap tenths of a second: the ratio grid
# reaches a discrepancy sd 1000 times the noise's (the default stops at 100)
discrepancy <- gp_discrepancy(ratio = c(0, 10^seq(-1, 6, by = 0.5)))
discrepancy_koh <- gp_discrepancy(ratio = c(0, 10^seq(-1, 6, by = 0.5)), orthogonal = FALSE)

inputs <- suppressMessages(read_calibration_inputs(
  design, ms * simobs, data.frame(radius = radii, ms * expobs[-1]), n_x = 1, t = h_sim,
  t_field = h_field, seed = 1))
fit_emulated <- timed(calibrate(inputs$library, inputs$field, seed = 1))
fit_emulated_gap <- timed(suppressWarnings(
  calibrate(inputs$library, inputs$field, discrepancy = discrepancy, seed = 1)))
fit_emulated_koh <- timed(suppressWarnings(
  calibrate(inputs$library, inputs$field, discrepancy = discrepancy_koh, seed = 1)))

# The simulator itself at the field's balls and heights: SEPIA's linear drag
balls <- data.frame(radius = radii)
at_balls <- function(theta) {
  p <- 1 + if (is.null(theta$extra_power)) 0 else theta$extra_power
  delay <- if (is.null(theta$delay)) 0 else theta$delay
  ms * do.call(cbind, lapply(radii, function(r) fall_times(theta$C, r, p, h_field) + delay))
}
g_base <- data.frame(C = seq(0.05, 0.25, length.out = 401))
base <- sim_library(g_base, at_balls(g_base), x = balls, t = h_field)
field <- inputs$field
fit_base <- timed(calibrate(base, field, seed = 1))
fit_base_gap <- timed(suppressWarnings(calibrate(base, field,
                                                 discrepancy = discrepancy, seed = 1)))
fit_base_koh <- timed(suppressWarnings(calibrate(base, field,
                                                 discrepancy = discrepancy_koh, seed = 1)))

# Two physical candidates, each 0 for the simulator as it is: a drag force
# growing faster than linearly with speed (v^(1 + extra_power)), and a timer
# started before the ball is released (by `delay` s)
g_power <- expand.grid(C = exp(seq(log(0.01), log(0.25), length.out = 201)),
                       extra_power = seq(0, 1.5, by = 0.1))
g_delay <- expand.grid(C = seq(0.05, 0.25, length.out = 201), delay = seq(0, 0.02, by = 0.002))
candidates <- list(drag_power = sim_library(g_power, at_balls(g_power), x = balls, t = h_field),
                   timer_delay = sim_library(g_delay, at_balls(g_delay), x = balls, t = h_field))
gap <- timed(diagnose_gap(fit_base, candidates, seed = 1))
# is there a gap, and where, with no candidate in hand
gap_none <- timed(diagnose_gap(fit_base, discrepancy = discrepancy, seed = 1))
# the discrepancy's posterior on the simulator's library
delta <- discrepancy_posterior(fit_base_gap, ndraws = 400, seed = 1)

fit_power <- suppressWarnings(calibrate(candidates$drag_power, field, seed = 1))
fit_power <- timed(refine(fit_power, simulator = at_balls, max_runs = 3000, seed = 1))
fit_power_gap <- timed(suppressWarnings(calibrate(fit_power$library, field,
                                                  discrepancy = discrepancy, seed = 1)))

# ---- what the vignette shows -------------------------------------------------------
fit_table <- function(fit) {
  s <- summary(fit)
  keep <- !s$parameter %in% c("tau", "delta_ratio")
  data.frame(parameter = s$parameter[keep], estimate = s$estimate[keep],
             lower = s$lower[keep], upper = s$upper[keep])
}
noise_sd <- function(fit) {
  s <- summary(fit)
  sqrt(1 / s$estimate[s$parameter == "tau"])
}
evidence <- function(fit) unclass(discrepancy_evidence(fit))[c("log_bayes_factor", "prob_none",
                                                               "ratio", "length_x", "length_t")]
seconds <- function(fit) attr(fit, "seconds")
fits <- list(emulated = fit_emulated, emulated_gap = fit_emulated_gap,
             emulated_koh = fit_emulated_koh, base = fit_base, base_gap = fit_base_gap,
             base_koh = fit_base_koh, power = fit_power, power_gap = fit_power_gap)

# where: the measurements less the best run of the simulator as it is (the
# posterior mode over runs) and of the candidate's, by ball and height
mode_run <- function(fit) which.max(fit$exact$run)
residuals_of <- function(fit, model) {
  run <- lib_outputs(fit$library, mode_run(fit))
  data.frame(model = model, radius = rep(radii, each = length(h_field)),
             height = rep(h_field, length(radii)),
             residual = ms * as.vector(t(as.matrix(expobs[-1]))) - as.vector(run))
}
where <- rbind(residuals_of(fit_base, "linear drag (the simulator)"),
               residuals_of(fit_power, "drag_power candidate"))

results <- list(
  made = format(Sys.Date()), session = R.version.string,
  sepia = list(commit = tryCatch(system2("git", c("--git-dir", shQuote(sepia_dir), "rev-parse",
                                                  "HEAD"), stdout = TRUE),
                                 warning = function(w) NA_character_)),
  tables = lapply(fits, fit_table), noise_sd = vapply(fits, noise_sd, numeric(1)),
  seconds = vapply(fits, seconds, numeric(1)),
  loglik = vapply(fits, function(f) as.numeric(logLik(f)), numeric(1)),
  evidence = lapply(fits[c("emulated_gap", "emulated_koh", "base_gap", "base_koh",
                           "power_gap")], evidence),
  # what each fit's summary() says theta is (theta_estimand())
  estimand = lapply(fits, function(f) attr(summary(f), "estimand")),
  gap = list(print = utils::capture.output(print(gap)), which = gap$which,
             shrinkage = gap$shrinkage, where = gap$where, seconds = attr(gap, "seconds")),
  no_candidates = list(which = gap_none$which, verdict = gap_none$verdict,
                       log_bayes_factor = gap_none$evidence$log_bayes_factor,
                       where = gap_none$where, seconds = attr(gap_none, "seconds")),
  delta = delta[c("radius", "t", "residual", "mean", "lower", "upper")],
  refined = fit_power$refinement[c("runs_added", "rounds", "reason")],
  where = where,
  truth = c(C = 0.1 / (4 * pi / 3), extra_power = 1))
saveRDS(results, file.path(out_dir, "real_data_gap.rds"), compress = "xz")
str(results, max.level = 1)
