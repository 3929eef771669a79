# Published data sets with a discrepancy (issue 23, item 5): griddy's
# calibrate(..., discrepancy = gp_discrepancy()) beside the published
# discrepancy models on the same data.
#   spot weld    Bayarri et al. (2007), shipped with the CRAN package SAVE
#                (archived; read from its tarball as bench/published-data.R
#                does): 35 runs of a spot-weld FE model, 120 field welds at 12
#                settings (replicated). Reference: SAVE's bias-corrected
#                posterior (bayesfit() with a GP bias), run here with SAVE
#                1.0's own example script inst/extdata/SpotweldExample.r
#                (same prior, iterations and seed) when SAVE is installed,
#                else the numbers recorded below from such a run.
#   ball drop 1  SEPIA's examples/Ball_Drop (lanl/SEPIA, BSD-3): 25 runs over
#                (radius, C) at 16 heights, 3 balls timed at 4 heights between
#                the simulator's. Reference: the posterior of C printed in
#                SEPIA's notebooks ball_drop_1.ipynb (with SEPIA's discrepancy
#                basis, 16 normal kernels) and ball_drop_1_noD.ipynb (without),
#                both 90% intervals, native scale ("theta_native").
#
# Run from the package root with griddy installed (or GRIDDY_LOAD_ALL=1 to
# load this checkout) and a copy of SEPIA's repository (a checkout or a bare
# git directory) at SEPIA_DIR:
#   SEPIA_DIR=/path/to/SEPIA Rscript bench/published-discrepancy.R
# Writes bench/results/published-discrepancy.md (and .csv).

if (nzchar(Sys.getenv("GRIDDY_LOAD_ALL"))) pkgload::load_all(".", quiet = TRUE) else library(griddy)
source("bench/helpers.R")  # load_save(), timing, md_table()
source(system.file("extdata", "real_data_gap_physics.R", package = "griddy"))  # fall_times()
out_md <- "bench/results/published-discrepancy.md"
level <- 0.9
rows <- list()
add_row <- function(data, method, fit = NULL, parameter, estimate, lower, upper, noise_sd = NA,
                    delta_sd = NA, log_bf = NA, seconds = NA, source = "") {
  rows[[length(rows) + 1L]] <<- data.frame(
    data = data, method = method, parameter = parameter, estimate = estimate, lower = lower,
    upper = upper, noise_sd = noise_sd, delta_sd = delta_sd, log_bf = log_bf,
    seconds = seconds, source = source)
}
timed <- function(expr) {
  start <- proc.time()[["elapsed"]]
  value <- force(expr)
  list(value = value, seconds = proc.time()[["elapsed"]] - start)
}
# griddy's row: the parameter's posterior mean and central interval at
# `level`, the noise sd at tau's posterior mean, and with a discrepancy its
# sd (sqrt(ratio / tau) at their posterior means) and the log Bayes factor
griddy_row <- function(data, method, t, parameter, source = "") {
  fit <- t$value
  s <- summary(fit, level = level)
  at <- function(p, col) s[[col]][s$parameter == p]
  tau <- at("tau", "estimate")
  has_gap <- "delta_ratio" %in% s$parameter
  add_row(data, method, parameter = parameter, estimate = at(parameter, "estimate"),
          lower = at(parameter, "lower"), upper = at(parameter, "upper"),
          noise_sd = 1 / sqrt(tau),
          delta_sd = if (has_gap) sqrt(at("delta_ratio", "estimate") / tau) else NA,
          log_bf = if (has_gap) discrepancy_evidence(fit)$log_bayes_factor else NA,
          seconds = t$seconds, source = source)
}

# ---- spot weld against SAVE -----------------------------------------------------
model <- load_save("spotweldmodel")
field <- load_save("spotweldfield")
x_names <- c("load", "current", "thickness")
inputs <- suppressMessages(read_calibration_inputs(design = model[c(x_names, "tuning")],
                                                   simobs = model["diameter"],
                                                   expobs = field[c(x_names, "diameter")],
                                                   n_x = 3, seed = 1))
plain <- timed(suppressWarnings(calibrate(inputs$library, inputs$field, seed = 1)))
griddy_row("spot weld", "griddy, no discrepancy", plain, "tuning")
with_gap <- timed(suppressWarnings(calibrate(inputs$library, inputs$field, seed = 1,
                                             discrepancy = gp_discrepancy())))
griddy_row("spot weld", "griddy, gp_discrepancy()", with_gap, "tuning")
spot_evidence <- discrepancy_evidence(with_gap$value)

# SAVE's functions re-read their own call (.expand.call), which fails from
# inside a function or as SAVE::: so at top level, with SAVE attached
save_ref <- NULL
if (requireNamespace("SAVE", quietly = TRUE)) {
  suppressPackageStartupMessages(library(SAVE))
  invisible(utils::capture.output(
    sw <- SAVE(response.name = "diameter", controllable.names = c("current", "load", "thickness"),
               calibration.names = "tuning", field.data = field, model.data = model,
               mean.formula = ~1, bestguess = list(tuning = 4.0))))
  set.seed(0)
  save_start <- proc.time()[["elapsed"]]
  invisible(utils::capture.output(
    sw <- bayesfit(object = sw, prior = c(uniform("tuning", upper = 8, lower = 0.8)),
                   n.iter = 20000, n.burnin = 100, n.thin = 2)))
  save_ref <- list(tuning = sw@mcmcsample[, "tuning"], lambdaB = sw@mcmcsample[, "lambdaB"],
                   lambdaF = sw@mcmcsample[, "lambdaF"],
                   seconds = proc.time()[["elapsed"]] - save_start,
                   source = "SAVE 1.0 bayesfit(), run here")
}
if (is.null(save_ref)) {
  # SAVE 1.0's example inst/extdata/SpotweldExample.r (set.seed(0), 20000
  # iterations, burn-in 100, thin 2), run on 2026-11-25 under R 4.2.2 with
  # DiceKriging from CRAN: summary(sw) printed these (the 90% bounds are the
  # 5% and 95% quantiles of its 9,950 draws).
  add_row("spot weld", "SAVE bias-corrected (bayesfit)", parameter = "tuning",
          estimate = 3.238, lower = 1.465, upper = 7.013, noise_sd = 1 / sqrt(4.964),
          delta_sd = 1 / sqrt(2.368), seconds = 63.5,
          source = "recorded SAVE 1.0 run (see the script)")
} else {
  q <- stats::quantile(save_ref$tuning, c((1 - level) / 2, (1 + level) / 2))
  add_row("spot weld", "SAVE bias-corrected (bayesfit)", parameter = "tuning",
          estimate = mean(save_ref$tuning), lower = q[[1]], upper = q[[2]],
          noise_sd = 1 / sqrt(mean(save_ref$lambdaF)), delta_sd = 1 / sqrt(mean(save_ref$lambdaB)),
          seconds = save_ref$seconds, source = save_ref$source)
}

# ---- ball drop 1 against SEPIA --------------------------------------------------
source("data-raw/sepia-ball-drop.R")  # design, h_sim, h_field, radii, expobs, numbers()
# sim.dat is SEPIA's layout, one column per run: read_calibration_inputs()
# takes it as it is, and t_field the field's heights between the simulator's
# (in ms: in seconds the misfits are so small that the default Gamma prior's
# rate on tau would not be negligible)
ms <- 1000
ball <- suppressMessages(read_calibration_inputs(design, ms * numbers("sim.dat"),
                                                 data.frame(radius = radii, ms * expobs[-1]),
                                                 n_x = 1, t = h_sim, t_field = h_field,
                                                 seed = 1))
ball_gap <- gp_discrepancy(ratio = c(0, 10^seq(-1, 6, by = 0.5)))
emulated <- timed(suppressWarnings(calibrate(ball$library, ball$field, seed = 1)))
griddy_row("ball drop 1", "griddy, emulated library, no discrepancy", emulated, "C")
emulated_gap <- timed(suppressWarnings(calibrate(ball$library, ball$field,
                                                 discrepancy = ball_gap, seed = 1)))
griddy_row("ball drop 1", "griddy, emulated library, gp_discrepancy()", emulated_gap, "C")
# the simulator itself (SEPIA's linear drag) instead of an emulator of its 25 runs
g_base <- data.frame(C = seq(0.05, 0.25, length.out = 401))
sim <- sim_library(g_base, ms * do.call(cbind, lapply(radii, function(r) {
  fall_times(g_base$C, r, 1, h_field)
})), x = data.frame(radius = radii), t = h_field)
exact <- timed(suppressWarnings(calibrate(sim, ball$field, seed = 1)))
griddy_row("ball drop 1", "griddy, simulator library, no discrepancy", exact, "C")
exact_gap <- timed(suppressWarnings(calibrate(sim, ball$field,
                                              discrepancy = ball_gap, seed = 1)))
griddy_row("ball drop 1", "griddy, simulator library, gp_discrepancy()", exact_gap, "C")
add_row("ball drop 1", "SEPIA, discrepancy basis (D)", parameter = "C", estimate = 0.1204,
        lower = 0.1085, upper = 0.1339,
        source = "examples/Ball_Drop/ball_drop_1.ipynb, param_stats theta_native")
add_row("ball drop 1", "SEPIA, discrepancy basis (D), second run", parameter = "C",
        estimate = 0.1201, lower = 0.1084, upper = 0.1320,
        source = "examples/Ball_Drop/ball_drop_1_parallelchains.ipynb, p_stats_ref")
add_row("ball drop 1", "SEPIA, no discrepancy", parameter = "C", estimate = 0.1330,
        lower = 0.1218, upper = 0.1423,
        source = "examples/Ball_Drop/ball_drop_1_noD.ipynb, param_stats theta_native")

# ---- the page ------------------------------------------------------------------
# How close griddy gets, and why it differs, from this run's numbers.
reading <- function(table) {
  get <- function(method, col) table[[col]][table$method == method]
  iv <- function(method) {
    sprintf("%.3g [%.3g, %.3g]", get(method, "estimate"), get(method, "lower"),
            get(method, "upper"))
  }
  g_sw <- "griddy, gp_discrepancy()"
  s_sw <- "SAVE bias-corrected (bayesfit)"
  e_bd <- "griddy, emulated library, gp_discrepancy()"
  d_bd <- "SEPIA, discrepancy basis (D)"
  c(
    "## How close griddy gets, and why it differs", "",
    paste0(
      "**Spot weld.** With `gp_discrepancy()` griddy's tuning is ", iv(g_sw), " against SAVE's ",
      iv(s_sw), " (90%): the intervals overlap over ",
      sprintf("%.0f%%", 100 * (min(get(g_sw, "upper"), get(s_sw, "upper")) -
                                 max(get(g_sw, "lower"), get(s_sw, "lower"))) /
                (get(g_sw, "upper") - get(g_sw, "lower"))),
      " of griddy's, the means differ by ", sprintf("%.2g", get(g_sw, "estimate") -
                                                      get(s_sw, "estimate")),
      ", and the noise sd agrees (", sprintf("%.3g", get(g_sw, "noise_sd")), " against ",
      sprintf("%.3g", get(s_sw, "noise_sd")), "): the replicates (120 welds at 12 settings) ",
      "pin the noise in both. Without a discrepancy griddy's interval is ",
      iv("griddy, no discrepancy"), ", narrow, SAVE's mean outside it, and the noise sd ",
      "inflated to ", sprintf("%.3g", get("griddy, no discrepancy", "noise_sd")),
      "; the discrepancy widens it and moves it toward SAVE's. The differences that remain ",
      "are the models': SAVE emulates the 35 runs with its own GP (plug-in maximum-likelihood ",
      "ranges) and gives the bias a product power-exponential correlation with ranges fixed at ",
      "their maximum-likelihood values (its range for thickness, betaB = 5e19, makes the bias ",
      "independent between the two thicknesses), sampling its precision by MCMC; griddy ",
      "emulates them with RobustGaSP's ppgasp (its library spans the design's tuning range, ",
      "0.80 to 7.71, against SAVE's uniform prior on 0.8 to 8) and integrates an isotropic ",
      "squared-exponential discrepancy over the scaled (load, current, thickness) on a grid ",
      "of ratios and lengths (0.1, 0.3, 1). The bias sd differs accordingly (",
      sprintf("%.2g", get(g_sw, "delta_sd")), " against SAVE's ",
      sprintf("%.2g", get(s_sw, "delta_sd")), "). SAVE took ",
      sprintf("%.0f", get(s_sw, "seconds")), " s, griddy ", sprintf("%.1f", get(g_sw, "seconds")),
      " s (one process each on a shared machine)."), "",
    paste0(
      "**Ball drop 1.** Without a discrepancy griddy's C on the emulated library, ",
      iv("griddy, emulated library, no discrepancy"), ", matches SEPIA's ",
      iv("SEPIA, no discrepancy"), " to the third digit. With one, griddy's ", iv(e_bd),
      " and SEPIA's ", iv(d_bd), " differ by ",
      sprintf("%.2g", get(e_bd, "estimate") - get(d_bd, "estimate")),
      " in the mean, under half SEPIA's posterior sd (0.0075), griddy's interval reaching ",
      "higher. They differ because (a) the discrepancy models differ: SEPIA's is 16 normal ",
      "kernels of width 1.5 m over the height with weights that are GPs over the radius, ",
      "griddy's a squared-exponential GP over (radius, height) with its ratio and lengths ",
      "integrated on a grid; (b) SEPIA's notebooks redraw the timing error (uniform on 0 to ",
      "10 ms, unseeded) on each run, so their field times differ from the published files' ",
      "by a few ms, small against a misfit of tenths of a second; (c) SEPIA's numbers come ",
      "from 1,000 MCMC draws whose effective size for theta its notebook prints as 26, a ",
      "Monte Carlo error of about 0.0015 in the mean. Both tools emulate the same 25 runs, ",
      "and both emulators pull C below what the simulator itself gives: on a library of ",
      "401 runs of the simulator's own equation (linear drag, ",
      "inst/extdata/real_data_gap_physics.R) griddy finds ",
      iv("griddy, simulator library, no discrepancy"), " without and ",
      iv("griddy, simulator library, gp_discrepancy()"), " with a discrepancy. ",
      "The field heights (5 to 20 m) are not among the simulator's (1.5 to 24 m by 1.5): ",
      "`read_calibration_inputs(t_field =)` takes them as published, and SEPIA's `sim.dat` ",
      "in its own layout (one column per run)."), "",
    "Noise and discrepancy sds of the ball drop are in ms; `delta_sd` is sqrt(ratio / tau) ",
    "at their posterior means, a rough scale, not a posterior mean of the sd.")
}
table <- do.call(rbind, rows)
utils::write.csv(table, sub("\\.md$", ".csv", out_md), row.names = FALSE)
shown <- table
for (col in c("estimate", "lower", "upper", "noise_sd", "delta_sd", "log_bf", "seconds")) {
  shown[[col]] <- fmt3(shown[[col]])
}
names(shown)[names(shown) == "lower"] <- "5%"
names(shown)[names(shown) == "upper"] <- "95%"
lines <- c(
  "# Published data sets with a discrepancy (bench/published-discrepancy.R)", "",
  paste0("griddy ", packageVersion("griddy"), ", ", format(Sys.Date()), ". ", machine_note(),
         ". Times are wall-clock on a shared machine."), "",
  paste0("Posterior mean and central ", 100 * level, "% interval of the calibration ",
         "parameter; `noise_sd` and `delta_sd` at the posterior means of the precision and ",
         "the discrepancy ratio (griddy) or of SAVE's lambdaF and lambdaB; `log_bf` the log ",
         "Bayes factor for a discrepancy (discrepancy_evidence())."), "",
  md_table(shown), "",
  "Spot weld, griddy's discrepancy evidence:", "", "```",
  utils::capture.output(print(spot_evidence)), "```", "", reading(table))
writeLines(lines, out_md)
cat(lines, sep = "\n")
