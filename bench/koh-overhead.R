# koh_calibrate()'s cost against RobustCalibration called directly, and
# griddy's calibrate() against both, on the published data sets the
# vignettes use (issue 36, items 2 and 4), in one R process:
#   spot weld          SAVE's spot weld (Bayarri et al. 2007; read from the
#                      archived CRAN tarball as bench/published-data.R does):
#                      griddy's emulated library of the 35 runs, 120 welds
#                      (10 replicates at 12 settings);
#   ball drop, emulated   SEPIA's ball drop 1 (lanl/SEPIA, BSD-3; SEPIA_DIR,
#                      as bench/published-discrepancy.R): the emulated
#                      library of its 25 runs, 3 balls at 4 heights (ms);
#   ball drop, simulator  the same field on a 401-run library of the
#                      simulator itself (SEPIA's linear drag, fall_times()).
# The two ball drops are published-discrepancy.R's two libraries.
#
# Per data set, with RobustCalibration's GaSP discrepancy and the chain of
# bench/published-discrepancy.R (KOH_ITER = 55,000 iterations, KOH_BURN =
# 15,000 dropped; koh_calibrate()'s default pilot tuning, 3 x 1,000):
#   koh_calibrate()        the wrapper, whole call (emulator, tuning, chain);
#   RC direct, same model  rcalibration() with the wrapper's math model and
#                          tuned proposal: the same chain without the
#                          wrapper (its emulator and tuning are the wrapper's
#                          added work, timed apart in koh_calibrate()'s
#                          `runtime`);
#   RC direct, own emulator  rcalibration() as its users call it on the same
#                          runs (simul_type = 0: its rgasp/ppgasp emulator of
#                          the runs, fitted inside the call; on the ball drop
#                          emulated library an rgasp over (radius, height, C),
#                          400 points), same proposal and chain length;
#   griddy, no discrepancy / gp_discrepancy()  calibrate() at its defaults
#                          (ball drop: published-discrepancy.R's ratio grid).
# Elapsed and CPU seconds (this process), the calibration parameter's
# effective samples (coda::effectiveSize and posterior::ess_bulk), seconds
# per effective sample, and ratios: koh_calibrate() over each direct call;
# griddy with a discrepancy against RC direct (own emulator) per fit and per
# effective sample. KOH_PROFILE=true profiles griddy's discrepancy fits that
# take longer than RobustCalibration (Rprof; top of by.self in the .md);
# KOH_SETS="spot weld;ball drop, simulator" runs some of the sets; KOH_OUT
# names the CSV (the .md beside it).
#
# Run from the package root (GRIDDY_LOAD_ALL=true for the source tree):
#   SEPIA_DIR=/work/.mirror/lanl+SEPIA/repo SAVE_TARBALL=/path/SAVE_1.0.tar.gz \
#     GRIDDY_LOAD_ALL=true Rscript bench/koh-overhead.R
# Writes bench/results/koh-overhead.csv and .md. About 10 minutes here.

source("bench/helpers.R")
load_griddy()
stopifnot(requireNamespace("RobustCalibration", quietly = TRUE))
library(data.table)
if (nzchar(Sys.getenv("SAVE_TARBALL"))) {
  file.copy(Sys.getenv("SAVE_TARBALL"), file.path(tempdir(), "SAVE_1.0.tar.gz"))
}
source(system.file("extdata", "real_data_gap_physics.R", package = "griddy"))  # fall_times()
out_csv <- Sys.getenv("KOH_OUT", "bench/results/koh-overhead.csv")
koh_iter <- as.integer(Sys.getenv("KOH_ITER", "55000"))
koh_burn <- as.integer(Sys.getenv("KOH_BURN", "15000"))
profile <- Sys.getenv("KOH_PROFILE") %in% c("true", "always")
# RobustCalibration's own emulator on the ball drop's emulated library is an
# rgasp over 400 (radius, height, C) points: ~20 ms an iteration here, so its
# chain runs a tenth of the length (KOH_OWN_FRACTION) and is scaled up
own_fraction <- c("ball drop, emulated" = as.numeric(Sys.getenv("KOH_OWN_FRACTION", "0.1")))
machine <- machine_note()
fmt <- function(v, d = 3) formatC(signif(v, d), format = "fg", digits = d, big.mark = ",")

# ---- the data sets --------------------------------------------------------------
model <- load_save("spotweldmodel")
weld_field <- load_save("spotweldfield")
x_names <- c("load", "current", "thickness")
spot <- suppressMessages(read_calibration_inputs(
  design = model[c(x_names, "tuning")], simobs = model["diameter"],
  expobs = weld_field[c(x_names, "diameter")], n_x = 3, seed = 1))
source("data-raw/sepia-ball-drop.R")  # design, h_sim, h_field, radii, expobs, numbers()
ms <- 1000
sim_dat <- ms * numbers("sim.dat")  # heights x runs
ball <- suppressMessages(read_calibration_inputs(design, sim_dat,
                                                 data.frame(radius = radii, ms * expobs[-1]),
                                                 n_x = 1, t = h_sim, t_field = h_field, seed = 1))
g_base <- data.frame(C = seq(0.05, 0.25, length.out = 401))
sim <- sim_library(g_base, ms * do.call(cbind, lapply(radii, function(r) {
  fall_times(g_base$C, r, 1, h_field)
})), x = data.frame(radius = radii), t = h_field)
ratio <- c(0, 10^seq(-1, 6, by = 0.5))  # published-discrepancy.R's ball-drop grid

# RobustCalibration's own emulator of each set's runs (simul_type = 0): the
# observable inputs of the runs beside theta, in the design's column order
own_emulator <- list(
  "spot weld" = list(input = as.matrix(model[c(x_names, "tuning")]),
                     output = as.matrix(model["diameter"])),
  "ball drop, emulated" = list(
    input = cbind(radius = rep(design$radius, each = length(h_sim)),
                  t = rep(h_sim, nrow(design)), C = rep(design$C, each = length(h_sim))),
    output = matrix(as.vector(sim_dat), ncol = 1L)),
  "ball drop, simulator" = list(input = as.matrix(g_base), output = lib_outputs(sim)))
sets <- list(
  "spot weld" = list(library = spot$library, field = spot$field, gap = gp_discrepancy()),
  "ball drop, emulated" = list(library = ball$library, field = ball$field,
                               gap = gp_discrepancy(ratio = ratio)),
  "ball drop, simulator" = list(library = sim, field = ball$field,
                                gap = gp_discrepancy(ratio = ratio)))

# ---- measuring ----------------------------------------------------------------------
rows <- list()
profiles <- list()
ess_of <- function(v) {
  c(ess_coda = unname(coda::effectiveSize(v)), ess_bulk = posterior::ess_bulk(v))
}
add <- function(data, method, m, draws, note = "", runtime = c(NA, NA, NA),
                per_ess = c(m$elapsed_s, m$cpu_s)) {
  e <- ess_of(draws)
  if (is.null(per_ess)) per_ess <- c(m$elapsed_s, m$cpu_s)
  rows[[length(rows) + 1L]] <<- data.table(
    s_per_ess = per_ess[1] / e[["ess_bulk"]], cpu_s_per_ess = per_ess[2] / e[["ess_bulk"]],
    data = data, method = method, elapsed_s = m$elapsed_s, cpu_s = m$cpu_s,
    koh_emulator_s = runtime[1], koh_tuning_s = runtime[2], koh_chain_s = runtime[3],
    ess_coda = e[["ess_coda"]], ess_bulk = e[["ess_bulk"]], mean = mean(draws),
    lower = stats::quantile(draws, 0.05, names = FALSE),
    upper = stats::quantile(draws, 0.95, names = FALSE), other_cores = m$other_cores,
    note = note)
}
rc_quiet <- function(...) {
  out <- NULL
  utils::capture.output(out <- RobustCalibration::rcalibration(...))
  out
}

# warm-up: under load_all() the package's functions are JIT-compiled on
# their first calls, which an installed (byte-compiled) griddy does not pay
invisible(suppressWarnings(calibrate(sim, ball$field, discrepancy = gp_discrepancy(),
                                     seed = 1, progress = FALSE)))
invisible(suppressWarnings(koh_calibrate(ball$library, ball$field, "GaSP", n_iter = 200,
                                         burn_in = 100, tune_rounds = 1, tune_iter = 100,
                                         seed = 1, progress = FALSE)))
chosen <- strsplit(Sys.getenv("KOH_SETS", paste(names(sets), collapse = ";")), ";")[[1]]
sets <- sets[chosen]
for (data in names(sets)) {
  s <- sets[[data]]
  par_name <- names(lib_theta(s$library))
  cat(data, "\n")
  # koh_calibrate(), whole call
  k <- measure_call(suppressWarnings(koh_calibrate(s$library, s$field, "GaSP", n_iter = koh_iter,
                                                   burn_in = koh_burn, seed = 1,
                                                   progress = FALSE)))
  kf <- k$value
  add(data, "koh_calibrate()", k, kf$draws[[par_name]],
      note = paste0("emulator ", round(kf$runtime[["emulator"]], 2), " s, tuning ",
                    round(kf$runtime[["tuning"]], 2), " s, chain ",
                    round(kf$runtime[["sampling"]], 2), " s"),
      runtime = unname(kf$runtime[c("emulator", "tuning", "sampling")]))
  # what rcalibration() receives from the wrapper, rebuilt outside it
  obs <- griddy:::koh_observations(s$library, s$field)
  observed <- !is.na(obs$y)
  design_obs <- kf$design[observed, , drop = FALSE]
  emulator <- kf$emulator
  math_model <- griddy:::koh_math_model(emulator, observed)
  sd_all <- c(kf$proposal_sd, rep(0.25, ncol(design_obs)), 0.25)
  common <- list(design = design_obs, observations = obs$values, p_theta = 1L,
                 theta_range = kf$theta_range, sd_proposal = sd_all, S = koh_iter,
                 S_0 = koh_burn, discrepancy_type = "GaSP")
  d1 <- measure_call(withr::with_seed(1, do.call(rc_quiet, c(common, list(
    simul_type = 1L, math_model = math_model)))))
  add(data, "RC direct, same model", d1, d1$value@post_sample[, 1],
      note = "rcalibration(simul_type = 1) with koh_calibrate()'s math model and proposal")
  own <- own_emulator[[data]]
  loc <- if (ncol(own$output) > 1L) seq_len(ncol(own$output))[observed]
  # a chain cut to `fraction` of the length where an iteration costs tens of
  # ms; its emulator's fit is timed apart and the chain's time scaled up
  fraction <- if (data %in% names(own_fraction)) own_fraction[[data]] else 1
  own_common <- modifyList(common, list(S = round(koh_iter * fraction),
                                        S_0 = round(koh_burn * fraction)))
  d2 <- measure_call(withr::with_seed(1, do.call(rc_quiet, c(own_common, list(
    simul_type = 0L, input_simul = own$input, output_simul = own$output,
    loc_index_emulator = loc)))))
  note <- paste0("rcalibration(simul_type = 0): ", d2$value@emulator_type, " on ",
                 nrow(own$input), " points, fitted in the call")
  if (fraction < 1) {
    fit_own <- measure_call(utils::capture.output(if (ncol(own$output) == 1L) {
      RobustGaSP::rgasp(design = own$input, response = own$output, nugget.est = FALSE)
    } else {
      RobustGaSP::ppgasp(design = own$input, response = own$output, nugget.est = FALSE)
    }))
    note <- paste0(note, "; chain of ", own_common$S, " iterations (", own_common$S_0,
                   " dropped), elapsed ", fmt(d2$elapsed_s), " s, emulator fit ",
                   fmt(fit_own$elapsed_s), " s; times scaled to ", koh_iter, " iterations")
    per_ess <- c(d2$elapsed_s, d2$cpu_s)  # at the length that ran, with its ESS
    d2$elapsed_s <- fit_own$elapsed_s + (d2$elapsed_s - fit_own$elapsed_s) / fraction
    d2$cpu_s <- fit_own$cpu_s + (d2$cpu_s - fit_own$cpu_s) / fraction
  } else {
    per_ess <- NULL
  }
  add(data, "RC direct, own emulator", d2, d2$value@post_sample[, 1], note = note,
      per_ess = per_ess)

  # griddy
  for (gap in c("none", "gp_discrepancy()")) {
    disc <- if (gap == "none") NULL else s$gap
    g <- measure_call(suppressWarnings(calibrate(s$library, s$field, discrepancy = disc,
                                                 seed = 1, progress = FALSE)))
    th <- lib_theta(g$value$library)[[par_name]][g$value$draws$run]
    add(data, paste0("griddy, ", if (gap == "none") "no discrepancy" else gap), g, th,
        note = paste0(g$value$control$n_iter, " iterations (", g$value$control$burn_in,
                      " burn-in)"))
    slower <- g$elapsed_s > min(d1$elapsed_s, d2$elapsed_s)
    if (profile && !is.null(disc) && (slower || Sys.getenv("KOH_PROFILE") == "always")) {
      prof <- tempfile()
      utils::Rprof(prof, interval = 0.01)
      invisible(suppressWarnings(calibrate(s$library, s$field, discrepancy = disc, seed = 1,
                                           progress = FALSE)))
      utils::Rprof(NULL)
      profiles[[data]] <- utils::head(utils::summaryRprof(prof)$by.self, 12)
    }
  }
}

# ---- the tables ---------------------------------------------------------------------
results <- rbindlist(rows)
setcolorder(results, c("data", "method"))
ref_of <- function(d, m, col) results[data == d & method == m][[col]]
results[, vs_rc_own := elapsed_s / vapply(data, ref_of, 0, m = "RC direct, own emulator",
                                          col = "elapsed_s")]
results[, vs_rc_own_cpu := cpu_s / vapply(data, ref_of, 0, m = "RC direct, own emulator",
                                          col = "cpu_s")]
results[, per_ess_vs_rc_own := s_per_ess / vapply(data, ref_of, 0,
                                                  m = "RC direct, own emulator",
                                                  col = "s_per_ess")]
results[, vs_rc_same := elapsed_s / vapply(data, ref_of, 0, m = "RC direct, same model",
                                           col = "elapsed_s")]
results[, machine := machine]
fwrite(results, out_csv)

shown <- results[, .(data, method, `elapsed s` = fmt(elapsed_s), `CPU s` = fmt(cpu_s),
                     `bulk ESS` = fmt(ess_bulk), `ESS (coda)` = fmt(ess_coda),
                     `s / ESS` = fmt(s_per_ess), `x RC own` = fmt(vs_rc_own, 2),
                     `x RC own (CPU)` = fmt(vs_rc_own_cpu, 2),
                     `per ESS x RC own` = fmt(per_ess_vs_rc_own, 2),
                     `x RC same` = fmt(vs_rc_same, 2),
                     `90% interval` = sprintf("%.3g [%.3g, %.3g]", mean, lower, upper), note)]
bars <- rbindlist(lapply(names(sets), function(d) {
  k <- results[data == d & method == "koh_calibrate()"]
  g <- results[data == d & method == "griddy, gp_discrepancy()"]
  data.table(data = d,
             `koh / RC own (bar 1.5)` = fmt(k$vs_rc_own, 2),
             `koh / RC same model` = fmt(k$vs_rc_same, 2),
             `koh chain / RC same model` = fmt(
               k$koh_chain_s / ref_of(d, "RC direct, same model", "elapsed_s"), 2),
             `griddy gap / RC own, per fit (bar < 1)` = fmt(g$vs_rc_own, 2),
             `griddy gap / RC same, per fit` = fmt(g$vs_rc_same, 2),
             `griddy gap / RC own, per ESS` = fmt(g$per_ess_vs_rc_own, 2))
}))
lines <- c(
  "# koh_calibrate() and griddy against RobustCalibration called directly (bench/koh-overhead.R)",
  "", paste0("griddy ", packageVersion("griddy"), ", RobustCalibration ",
             packageVersion("RobustCalibration"), ", ", format(Sys.Date()), ". ", machine,
             ". One process; a shared, loaded machine: ratios, not absolute times. ",
             "RobustCalibration's chains: ", koh_iter, " iterations, ", koh_burn,
             " dropped, GaSP discrepancy. ESS of the calibration parameter ",
             "(posterior::ess_bulk; coda beside it); s / ESS = elapsed / bulk ESS (a ",
             "shortened chain: its own elapsed and ESS). ",
             "`other_cores` in the CSV: cores other processes kept busy meanwhile."), "",
  md_table(shown), "", "Bars (issue 36): koh_calibrate() within 1.5x RobustCalibration ",
  "called directly; griddy with a discrepancy faster per fit than RobustCalibration.", "",
  md_table(bars), "")
for (d in names(profiles)) {
  lines <- c(lines, paste0("Rprof of griddy's gp_discrepancy() fit, ", d, " (by.self, top 12):"),
             "", "```", utils::capture.output(print(profiles[[d]])), "```", "")
}
writeLines(lines, sub("\\.csv$", ".md", out_csv))
cat(lines, sep = "\n")
