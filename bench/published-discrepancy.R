# Published data sets with a discrepancy (issue 23, item 5; issue 33, item
# 3): griddy's calibrate(..., discrepancy = ) beside the published
# discrepancy models on the same data, like for like. griddy's default
# (orthogonal) discrepancy estimates the best-fitting theta (the L2
# projection); gp_discrepancy(orthogonal = FALSE) estimates Kennedy and
# O'Hagan's theta, which SEPIA, SAVE and RobustCalibration report, and
# (scaled = TRUE, orthogonal = FALSE) is the analogue of RobustCalibration's
# S-GaSP. RobustCalibration (GaSP and S-GaSP) is run here on both data sets,
# with griddy's emulator of the same runs as its math model.
#   spot weld    Bayarri et al. (2007), shipped with the CRAN package SAVE
#                (archived, GPL-2 | GPL-3; read from its tarball as
#                bench/published-data.R does): 35 runs of a spot-weld FE
#                model, 120 field welds at 12 settings (replicated).
#                Reference: SAVE's bias-corrected
#                posterior (bayesfit() with a GP bias), run here with SAVE
#                1.0's own example script inst/extdata/SpotweldExample.r
#                (same prior, iterations and seed 0, and seeds 1 and 2)
#                when SAVE is installed, else the numbers recorded below
#                from such a run.
#   ball drop 1  SEPIA's examples/Ball_Drop (lanl/SEPIA, BSD-3): 25 runs over
#                (radius, C) at 16 heights, 3 balls timed at 4 heights between
#                the simulator's. Reference: the posterior of C printed in
#                SEPIA's notebooks ball_drop_1.ipynb (with SEPIA's discrepancy
#                basis, 16 normal kernels) and ball_drop_1_noD.ipynb (without),
#                both 90% intervals, native scale ("theta_native"), read
#                from the notebooks' stored outputs (sepia_theta()).
#
# Run from the package root with griddy installed (or GRIDDY_LOAD_ALL=1 to
# load this checkout) and a copy of SEPIA's repository (a checkout or a bare
# git directory) at SEPIA_DIR:
#   SEPIA_DIR=/path/to/SEPIA Rscript bench/published-discrepancy.R
# SAVE 1.0 from the CRAN archive can go in a private library:
#   R_LIBS_USER=/tmp/savelib Rscript -e 'install.packages("DiceKriging");
#     install.packages("https://cran.r-project.org/src/contrib/Archive/SAVE/SAVE_1.0.tar.gz",
#                      repos = NULL, type = "source")'
# Writes bench/results/published-discrepancy.md (and .csv), and the table
# the vignette "Real data" reads, inst/extdata/published_discrepancy.csv.
# About 15 minutes (RobustCalibration's chains take most of it).

if (nzchar(Sys.getenv("GRIDDY_LOAD_ALL"))) pkgload::load_all(".", quiet = TRUE) else library(griddy)
source("bench/helpers.R")  # load_save(), timing, md_table()
source(system.file("extdata", "real_data_gap_physics.R", package = "griddy"))  # fall_times()
out_md <- "bench/results/published-discrepancy.md"
out_shipped <- "inst/extdata/published_discrepancy.csv"
level <- 0.9
# RobustCalibration's chains: 55,000 iterations, the first 15,000 (griddy's
# default burn-in) dropped, after koh_calibrate()'s pilot tuning
koh_iter <- 55000L
koh_burn <- 15000L
estimands <- c(none = "no discrepancy (best fit)", orthogonal = "best-fitting (L2 projection)",
               koh = "Kennedy-O'Hagan")
rows <- list()
# `prior_lower`, `prior_upper`: the range of the parameter's prior (griddy:
# the library's; RobustCalibration: its theta_range, the same; SAVE: its
# uniform prior; SEPIA: the design's range, on which it scales theta to [0,
# 1] under a Normal(0.5, 10) truncated there)
add_row <- function(data, method, estimand, parameter, estimate, lower, upper, mcse = NA,
                    noise_sd = NA, delta_sd = NA, log_bf = NA, seconds = NA, source = "",
                    prior = c(NA, NA)) {
  rows[[length(rows) + 1L]] <<- data.frame(
    data = data, method = method, estimand = estimand, parameter = parameter,
    estimate = estimate, lower = lower, upper = upper, mcse = mcse, noise_sd = noise_sd,
    delta_sd = delta_sd, log_bf = log_bf, seconds = seconds, source = source,
    prior_lower = prior[1], prior_upper = prior[2])
}
timed <- function(expr) {
  start <- proc.time()[["elapsed"]]
  value <- force(expr)
  list(value = value, seconds = proc.time()[["elapsed"]] - start)
}
estimand_of <- function(discrepancy) {
  if (is.null(discrepancy)) estimands[["none"]] else if (discrepancy$orthogonal) {
    estimands[["orthogonal"]]
  } else {
    estimands[["koh"]]
  }
}
# griddy's row: the parameter's posterior mean and central interval at
# `level`, the noise sd at tau's posterior mean, and with a discrepancy its
# sd (sqrt(ratio / tau) at their posterior means) and the log Bayes factor
griddy_fit_row <- function(data, method, library, field, discrepancy, parameter) {
  t <- timed(suppressWarnings(calibrate(library, field, discrepancy = discrepancy, seed = 1)))
  s <- summary(t$value, level = level)
  at <- function(p, col) s[[col]][s$parameter == p]
  tau <- at("tau", "estimate")
  has_gap <- !is.null(discrepancy)
  add_row(data, method, estimand_of(discrepancy), parameter = parameter,
          estimate = at(parameter, "estimate"), lower = at(parameter, "lower"),
          upper = at(parameter, "upper"), mcse = at(parameter, "mcse"),
          noise_sd = 1 / sqrt(tau),
          delta_sd = if (has_gap) sqrt(at("delta_ratio", "estimate") / tau) else NA,
          log_bf = if (has_gap) discrepancy_evidence(t$value)$log_bayes_factor else NA,
          seconds = t$seconds, prior = range(lib_theta(library)[[parameter]]))
  invisible(t$value)
}
# an MCMC reference's row from its draws of the parameter
draws_row <- function(data, method, draws, noise_var = NULL, delta_var = NULL, seconds = NA,
                      source = "", prior = c(NA, NA)) {
  q <- stats::quantile(draws, c((1 - level) / 2, (1 + level) / 2), names = FALSE)
  add_row(data, method, estimands[["koh"]], parameter = parameter_of(data),
          estimate = mean(draws), lower = q[1], upper = q[2],
          mcse = posterior::mcse_mean(draws),
          noise_sd = if (!is.null(noise_var)) 1 / sqrt(mean(1 / noise_var)) else NA,
          delta_sd = if (!is.null(delta_var)) sqrt(mean(delta_var)) else NA,
          seconds = seconds, source = source, prior = prior)
}
parameter_of <- function(data) c("spot weld" = "tuning", "ball drop 1" = "C")[[data]]
# RobustCalibration's discrepancy variance is sigma2_0 / eta (its
# parameterisation since 0.5: Cov = sigma2_0 (R / eta + I)), eta
# exp(log eta), the column after the log inverse ranges
rc_variances <- function(post, p_x) {
  list(noise = post[, ncol(post)], delta = post[, ncol(post)] / exp(post[, 1L + p_x + 1L]))
}

# ---- spot weld against SAVE and RobustCalibration --------------------------------
model <- load_save("spotweldmodel")
field <- load_save("spotweldfield")
x_names <- c("load", "current", "thickness")
inputs <- suppressMessages(read_calibration_inputs(design = model[c(x_names, "tuning")],
                                                   simobs = model["diameter"],
                                                   expobs = field[c(x_names, "diameter")],
                                                   n_x = 3, seed = 1))
sw <- function(method, discrepancy) {
  griddy_fit_row("spot weld", method, inputs$library, inputs$field, discrepancy, "tuning")
}
sw("griddy, no discrepancy", NULL)
with_gap <- sw("griddy, gp_discrepancy() (orthogonal)", gp_discrepancy())
spot_evidence <- discrepancy_evidence(with_gap)
sw("griddy, gp_discrepancy(orthogonal = FALSE)", gp_discrepancy(orthogonal = FALSE))
sw("griddy, gp_discrepancy(orthogonal = FALSE, scaled = TRUE)",
   gp_discrepancy(orthogonal = FALSE, scaled = TRUE))

# SAVE, with its example's settings (inst/extdata/SpotweldExample.r: uniform
# prior on 0.8 to 8, 20000 iterations, burn-in 100, thin 2). SAVE() fits its
# emulator and the bias's ranges with DiceKriging, from random starting
# points, and keeps state between calls in one session (a second fit there
# gave another posterior), so each fit runs in a fresh R process, with the
# seed set before SAVE() and before bayesfit(): seed 0 is the example's,
# seeds 1 and 2 show how much SAVE's own answer moves. SAVE's functions
# re-read their own call (.expand.call), so the fit is a top-level script.
save_prior <- c(0.8, 8)
save_fit <- function(seed) {
  script <- tempfile(fileext = ".R")
  out <- tempfile(fileext = ".rds")
  writeLines(c(
    "suppressPackageStartupMessages(library(SAVE))",
    "data(spotweldfield, package = 'SAVE'); data(spotweldmodel, package = 'SAVE')",
    sprintf("set.seed(%d)", seed),
    "invisible(capture.output(sw <- SAVE(response.name = 'diameter',",
    "  controllable.names = c('current', 'load', 'thickness'), calibration.names = 'tuning',",
    "  field.data = spotweldfield, model.data = spotweldmodel, mean.formula = ~1,",
    "  bestguess = list(tuning = 4.0))))",
    sprintf("set.seed(%d)", seed),
    "start <- proc.time()[['elapsed']]",
    "invisible(capture.output(sw <- bayesfit(object = sw,",
    sprintf("  prior = c(uniform('tuning', lower = %g, upper = %g)), n.iter = 20000,",
            save_prior[1], save_prior[2]),
    "  n.burnin = 100,",
    "  n.thin = 2)))",
    "seconds <- proc.time()[['elapsed']] - start",
    sprintf("saveRDS(list(draws = sw@mcmcsample, seconds = seconds), '%s')", out)), script)
  status <- system2(file.path(R.home("bin"), "Rscript"), script)
  if (status != 0L || !file.exists(out)) return(NULL)
  readRDS(out)
}
save_seeds <- if (requireNamespace("SAVE", quietly = TRUE)) c(0L, 1L, 2L) else integer(0)
for (seed in save_seeds) {
  ref <- save_fit(seed)
  if (is.null(ref)) next
  draws_row("spot weld", if (seed == 0L) "SAVE bias-corrected (bayesfit)" else
              paste0("SAVE bias-corrected (bayesfit), seed ", seed),
            ref$draws[, "tuning"], noise_var = 1 / ref$draws[, "lambdaF"],
            delta_var = 1 / ref$draws[, "lambdaB"], seconds = ref$seconds,
            source = paste0("SAVE 1.0 bayesfit(), run here, seed ", seed), prior = save_prior)
}
if (!any(vapply(rows, function(r) r$method == "SAVE bias-corrected (bayesfit)", TRUE))) {
  # SAVE 1.0's example inst/extdata/SpotweldExample.r (set.seed(0), 20000
  # iterations, burn-in 100, thin 2), run on 2026-11-25 under R 4.2.2 with
  # DiceKriging from CRAN: summary(sw) printed these (the 90% bounds are the
  # 5% and 95% quantiles of its 9,950 draws).
  add_row("spot weld", "SAVE bias-corrected (bayesfit)", estimands[["koh"]], parameter = "tuning",
          estimate = 3.238, lower = 1.465, upper = 7.013, noise_sd = 1 / sqrt(4.964),
          delta_sd = 1 / sqrt(2.368), seconds = 63.5,
          source = "recorded SAVE 1.0 run (see the script)", prior = save_prior)
}

# RobustCalibration on the replicated welds: koh_calibrate() takes no
# replicates, so rcalibration() is called here as koh_calibrate() calls it
# (the same pilot tuning), with the welds as a 12 x 10 matrix, one row per
# setting, which rcalibration() reduces to the settings' means and their
# pure error. Its math model is griddy's: the emulated library's runs
# (griddy's emulator of the 35 runs), interpolated linearly in the tuning
# (calling the emulator at each iteration took 10 ms); and, to see what the
# emulator does, RobustCalibration's own (simul_type = 0: an rgasp emulator
# of the 35 runs over the settings and the tuning, as its users run it).
settings <- as.matrix(lib_x(inputs$library)[x_names])
key <- function(d) do.call(paste, as.data.frame(d))
welds <- t(vapply(key(settings), function(k) {
  field$diameter[key(field[x_names]) == k]
}, numeric(10)))
tuning <- lib_theta(inputs$library)$tuning
by_tuning <- order(tuning)
tuning <- tuning[by_tuning]
runs <- as.matrix(lib_outputs(inputs$library))[by_tuning, , drop = FALSE]
interpolated <- function(x, th) {
  i <- findInterval(th, tuning, all.inside = TRUE)
  w <- (th - tuning[i]) / (tuning[i + 1L] - tuning[i])
  (1 - w) * runs[i, ] + w * runs[i + 1L, ]
}
theta_range <- matrix(range(tuning), 1L)
rc_replicated <- function(type, seed, own_emulator = FALSE) {
  run <- function(frac, S, S_0, start) {
    simulator <- if (own_emulator) {
      list(simul_type = 0L, input_simul = as.matrix(model[c(x_names, "tuning")]),
           output_simul = model$diameter)
    } else {
      list(simul_type = 1L, math_model = interpolated)
    }
    out <- NULL
    utils::capture.output(out <- do.call(RobustCalibration::rcalibration, c(list(
      design = settings, observations = welds, p_theta = 1L, theta_range = theta_range,
      sd_proposal = c(frac, rep(0.25, ncol(settings)), 0.25), S = S, S_0 = S_0,
      discrepancy_type = type, initial_values = start), simulator)))
    out
  }
  withr::with_seed(seed, {
    frac <- 0.02
    start <- mean(theta_range)
    for (r in 1:3) {  # koh_calibrate()'s tuning: 3 pilots of 1000
      pilot <- run(frac, 1000L, 0L, start)
      d <- pilot@post_sample[, 1]
      start <- d[length(d)]
      half <- d[-seq_len(500)]
      frac <- if (pilot@accept_S[1] / 1000 < 0.05 || stats::sd(half) <= 0) {
        frac / 5
      } else {
        2.38 * stats::sd(half) / diff(theta_range[1, ])
      }
    }
    run(frac, koh_iter, koh_burn, start)
  })
}
rc_spot <- list("RobustCalibration GaSP" = list("GaSP", FALSE),
                "RobustCalibration S-GaSP" = list("S-GaSP", FALSE),
                "RobustCalibration GaSP, its own emulator" = list("GaSP", TRUE))
for (method in names(rc_spot)) {
  t <- timed(rc_replicated(rc_spot[[method]][[1]], seed = 1, own_emulator = rc_spot[[method]][[2]]))
  post <- as.matrix(t$value@post_sample)
  v <- rc_variances(post, ncol(settings))
  draws_row("spot weld", method, post[, 1], noise_var = v$noise, delta_var = v$delta,
            seconds = t$seconds, prior = theta_range[1, ],
            source = paste0("RobustCalibration ", packageVersion("RobustCalibration"),
                            " rcalibration(), run here"))
}

# ---- ball drop 1 against SEPIA and RobustCalibration --------------------------------
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
# the simulator itself (SEPIA's linear drag) instead of an emulator of its 25 runs
g_base <- data.frame(C = seq(0.05, 0.25, length.out = 401))
sim <- sim_library(g_base, ms * do.call(cbind, lapply(radii, function(r) {
  fall_times(g_base$C, r, 1, h_field)
})), x = data.frame(radius = radii), t = h_field)
# the noise is a few ms and the gap tenths of a second: the ratio grid
# reaches a discrepancy sd 1000 times the noise's (the default stops at 100)
ratio <- c(0, 10^seq(-1, 6, by = 0.5))
# SEPIA's discrepancy in griddy's terms: 16 normal kernels of sd 1.5 m, 1.5 m
# apart, with independent weights, have correlation exp(-(h - h')^2 / (4 *
# 1.5^2)) over the height, a squared exponential of length 2 * 1.5 m (on the
# field's heights scaled to [0, 1], 3 / 15); the weights' correlation over
# the radius is rho^(4 d^2) (d on the design's radius range), and at rho's
# prior mean under SEPIA's Beta(1, 0.1), 1 / 1.1, that is a squared
# exponential of length 1 / sqrt(-4 log(1 / 1.1)) on that range
kernel_sd <- 1.5
sepia_length_t <- 2 * kernel_sd / diff(range(h_field))
sepia_length_x <- 1 / sqrt(-4 * log(1 / 1.1)) * diff(range(design$radius)) / diff(range(radii))
ball_gaps <- list(
  "gp_discrepancy() (orthogonal)" = gp_discrepancy(ratio = ratio),
  "gp_discrepancy(orthogonal = FALSE)" = gp_discrepancy(ratio = ratio, orthogonal = FALSE),
  "gp_discrepancy(orthogonal = FALSE, scaled = TRUE)" =
    gp_discrepancy(ratio = ratio, orthogonal = FALSE, scaled = TRUE),
  "gp_discrepancy(orthogonal = FALSE), SEPIA's lengths" =
    gp_discrepancy(ratio = ratio, orthogonal = FALSE, length_x = sepia_length_x,
                   length_t = sepia_length_t))
libraries <- list("emulated library" = ball$library, "simulator library" = sim)
for (lib_name in names(libraries)) {
  griddy_fit_row("ball drop 1", paste0("griddy, ", lib_name, ", no discrepancy"),
                 libraries[[lib_name]], ball$field, NULL, "C")
  for (gap in names(ball_gaps)) {
    griddy_fit_row("ball drop 1", paste0("griddy, ", lib_name, ", ", gap),
                   libraries[[lib_name]], ball$field, ball_gaps[[gap]], "C")
  }
  for (type in c("GaSP", "S-GaSP")) {
    t <- timed(suppressWarnings(koh_calibrate(libraries[[lib_name]], ball$field, type,
                                              n_iter = koh_iter, burn_in = koh_burn, seed = 1)))
    draws_row("ball drop 1", paste0("RobustCalibration ", type, ", ", lib_name),
              t$value$draws$C, noise_var = t$value$draws$sigma2, seconds = t$seconds,
              prior = t$value$theta_range[1, ],
              source = paste0("koh_calibrate() (RobustCalibration ",
                              packageVersion("RobustCalibration"), "), run here"))
  }
}
sepia_rows <- list(
  list(method = "SEPIA, discrepancy basis (D)", notebook = "ball_drop_1", which = 1L),
  list(method = "SEPIA, discrepancy basis (D), second run",
       notebook = "ball_drop_1_parallelchains", which = 1L),
  list(method = "SEPIA, no discrepancy", notebook = "ball_drop_1_noD", which = 1L))
for (r in sepia_rows) {
  th <- sepia_theta(r$notebook, r$which)
  add_row("ball drop 1", r$method,
          if (grepl("no discrepancy", r$method)) estimands[["none"]] else estimands[["koh"]],
          parameter = "C", estimate = th$mean, lower = th$lower, upper = th$upper,
          mcse = th$sd / sqrt(th$ess), source = paste0(th$source, ", param_stats theta_native"),
          prior = range(design$C))
}

# ---- the page ------------------------------------------------------------------
# How close griddy gets, and why it differs, from this run's numbers.
reading <- function(table) {
  get <- function(data, method, col) table[[col]][table$data == data & table$method == method]
  iv <- function(data, method) {
    sprintf("%.3g [%.3g, %.3g]", get(data, method, "estimate"), get(data, method, "lower"),
            get(data, method, "upper"))
  }
  width <- function(data, method) get(data, method, "upper") - get(data, method, "lower")
  ratio <- function(data, a, b) sprintf("%.2g", width(data, a) / width(data, b))
  sw <- "spot weld"
  bd <- "ball drop 1"
  s_orth <- "griddy, gp_discrepancy() (orthogonal)"
  s_koh <- "griddy, gp_discrepancy(orthogonal = FALSE)"
  s_sc <- "griddy, gp_discrepancy(orthogonal = FALSE, scaled = TRUE)"
  s_save <- "SAVE bias-corrected (bayesfit)"
  e <- function(rest) paste0("griddy, emulated library, ", rest)
  s <- function(rest) paste0("griddy, simulator library, ", rest)
  koh <- "gp_discrepancy(orthogonal = FALSE)"
  sepia <- "SEPIA, discrepancy basis (D)"
  c(
    "## Like for like, and why differences remain", "",
    paste0(
      "**Spot weld.** SAVE's Kennedy-O'Hagan tuning is ", iv(sw, s_save), " (90%). griddy's ",
      "orthogonal default, ", iv(sw, s_orth), ", estimates the best-fitting tuning instead; ",
      "with `orthogonal = FALSE` griddy estimates SAVE's quantity: ", iv(sw, s_koh),
      ", an interval ", ratio(sw, s_koh, s_save), " times SAVE's width (the orthogonal one ",
      ratio(sw, s_orth, s_save), "). RobustCalibration on griddy's emulator of the same runs ",
      "gives ", iv(sw, "RobustCalibration GaSP"), " (GaSP) and ",
      iv(sw, "RobustCalibration S-GaSP"), " (S-GaSP), and with its own rgasp emulator ",
      iv(sw, "RobustCalibration GaSP, its own emulator"), " (the same emulator); griddy's ",
      "S-GaSP analogue (`scaled = TRUE, orthogonal = FALSE`) ", iv(sw, s_sc), ". SAVE ",
      "with seeds 1 and 2 gives ", iv(sw, paste0(s_save, ", seed 1")), " and ",
      iv(sw, paste0(s_save, ", seed 2")), ". What remains is the ",
      "models': SAVE emulates the 35 runs with its own GP (DiceKriging, plug-in ",
      "maximum-likelihood ranges), fixes the bias's power-exponential ranges at their ",
      "maximum-likelihood values (for thickness, 5e19: a bias independent between the two ",
      "thicknesses) and puts exponential priors with the maximum-likelihood means on the ",
      "bias and noise precisions; RobustCalibration integrates a Matérn 5/2 discrepancy's ",
      "ranges and nugget under its jointly robust prior; griddy integrates an isotropic ",
      "squared-exponential discrepancy over a grid of ratios (log-uniform, 0.1 to 1e4, ",
      "and none at prior 0.5) and lengths (0.1, 0.3, 1)."), "",
    paste0(
      "**Ball drop 1.** SEPIA's C with its discrepancy is ", iv(bd, sepia),
      " (Monte Carlo error of its mean about ", sprintf("%.2g", get(bd, sepia, "mcse")),
      "). On the same emulated library, griddy's orthogonal default gives ",
      iv(bd, e("gp_discrepancy() (orthogonal)")), " (best-fitting C, ",
      ratio(bd, e("gp_discrepancy() (orthogonal)"), sepia), " times SEPIA's width) and ",
      "`orthogonal = FALSE` ", iv(bd, e(koh)), " (",
      ratio(bd, e(koh), sepia), " times); RobustCalibration ",
      iv(bd, "RobustCalibration GaSP, emulated library"), " (GaSP) and ",
      iv(bd, "RobustCalibration S-GaSP, emulated library"), " (S-GaSP). With SEPIA's ",
      "discrepancy shape in griddy's kernel (length over the height ",
      sprintf("%.2g", sepia_length_t), ", over the radius ", sprintf("%.2g", sepia_length_x),
      ", on scaled coordinates; see the script) griddy gives ",
      iv(bd, e(paste0(koh, ", SEPIA's lengths"))), ". On the simulator's own ",
      "library the Kennedy-O'Hagan C is ", iv(bd, s(koh)), " (griddy) and ",
      iv(bd, "RobustCalibration GaSP, simulator library"),
      " (RobustCalibration GaSP): the emulator of 25 runs moves C as well."), "",
    "Noise and discrepancy sds of the ball drop are in ms; `delta_sd` is sqrt(ratio / tau) ",
    "at their posterior means (griddy), or the root of the posterior mean of the ",
    "discrepancy's variance (SAVE, RobustCalibration): a rough scale. `mcse` is the Monte ",
    "Carlo standard error of the mean (SEPIA: its sd over the root of the effective sample ",
    "size its notebook prints).")
}
table <- do.call(rbind, rows)
utils::write.csv(table, sub("\\.md$", ".csv", out_md), row.names = FALSE)
# what the vignette reads: the same table, with what made it
shipped <- table
shipped$made <- format(Sys.Date())
utils::write.csv(shipped, out_shipped, row.names = FALSE)
shown <- table
for (col in c("estimate", "lower", "upper", "mcse", "noise_sd", "delta_sd", "log_bf",
              "seconds")) {
  shown[[col]] <- fmt3(shown[[col]])
}
names(shown)[names(shown) == "lower"] <- "5%"
names(shown)[names(shown) == "upper"] <- "95%"
lines <- c(
  "# Published data sets with a discrepancy (bench/published-discrepancy.R)", "",
  paste0("griddy ", packageVersion("griddy"), ", ", format(Sys.Date()), ". ", machine_note(),
         ". Times are wall-clock on a shared machine."), "",
  paste0("Posterior mean and central ", 100 * level, "% interval of the calibration ",
         "parameter, and what it estimates (`estimand`); `noise_sd` and `delta_sd` at the ",
         "posterior means of the precision and the discrepancy ratio (griddy) or of the ",
         "references' noise and discrepancy variances; `log_bf` the log Bayes factor for a ",
         "discrepancy (discrepancy_evidence()). RobustCalibration ran ", koh_iter,
         " iterations (", koh_burn, " dropped) on griddy's emulator of the same runs."), "",
  md_table(shown), "",
  "Spot weld, griddy's discrepancy evidence (orthogonal default):", "", "```",
  utils::capture.output(print(spot_evidence)), "```", "", reading(table))
writeLines(lines, out_md)
cat(lines, sep = "\n")
