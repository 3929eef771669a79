# Al-5083 (issue 24, item 5): eleven parameters, real data, no simulator.
# SEPIA's flyer-plate example (lanl/SEPIA, examples/Al_5083; read by
# data-raw/sepia-al5083.R the way SEPIA's Al_5083_calibration.py reads it):
# 1,000 runs of 11 strength parameters, 12 features (4 per shot, shots 104,
# 105, 106), one measurement of each with SEPIA's known observation sd.
#
# Through griddy's documented API only: sim_library(), field_data(sd =),
# calibrate(), then refine() without a simulator (its runs are predicted
# from the library), twice (the second call carries on from the first), and
# what each says: summary, adequacy (effective runs, Pareto k-hat, resolved
# or limited), warnings and run time. Then an independent reference
# (data-raw/al5083-reference.R: a Gaussian-process emulator of the 1,000 runs
# and a differential-evolution MCMC on it, then importance sampling from the
# chains' draws, the same likelihood) and the comparison.
#
# SEPIA's own posterior is not used: examples/Al_5083/data/sepia_mcmc_samples10000.pkl
# is listed in the repository's tree but its content was not in the snapshot
# read (commit 30989042, 2023-10-02; `git show` fails on the blob), and the
# notebook Al_5083_calibration.ipynb, which might show its numbers, neither;
# README.md and Al_5083_calibration.py give no posterior numbers.
#
# The raw data are not shipped (about 750 kB); the results are, in
# inst/extdata/al5083.rds (xz). Run from the package root with SEPIA's
# repository (a checkout or a bare git directory) at SEPIA_DIR:
#   SEPIA_DIR=/path/to/SEPIA Rscript data-raw/al5083.R
# About 30 minutes on a shared 2-core machine, nearly all of it the
# reference (griddy's part: about a minute); AL5083_REFERENCE=file reuses (or, if absent, writes) the
# reference's result there, and AL5083_EMULATORS=file its two ppgasp fits
# (about 160 MB).
pkgload::load_all(".", quiet = TRUE)
source("data-raw/sepia-al5083.R")
source("data-raw/al5083-reference.R")
set.seed(20261127)
load_average <- function() {
  tryCatch(scan("/proc/loadavg", what = numeric(), n = 3, quiet = TRUE),
           error = function(e) rep(NA_real_, 3))
}

# ---- griddy, through the documented API ----------------------------------------------
# every warning and message, with its class, and the time
recorded <- function(expr) {
  conditions <- list()
  keep <- function(cnd) {
    conditions[[length(conditions) + 1L]] <<- list(
      class = grep("^griddy_", class(cnd), value = TRUE)[1],
      message = conditionMessage(cnd))
  }
  start <- proc.time()[["elapsed"]]
  load <- load_average()
  value <- withCallingHandlers(expr,
                               warning = function(w) { keep(w); invokeRestart("muffleWarning") },
                               message = function(m) { keep(m); invokeRestart("muffleMessage") })
  list(fit = value, conditions = conditions, seconds = proc.time()[["elapsed"]] - start,
       load = load)
}

lib <- sim_library(al_design, al_sim)
field <- field_data(al_obs, sd = al_obs_sd)
base <- recorded(calibrate(lib, field, seed = 1))
# one call of refine() adds max_runs runs; the second carries on from the first
stage1 <- recorded(refine(base$fit, max_runs = 21000, seed = 1))
stage2 <- recorded(refine(stage1$fit, max_runs = 21000, seed = 2))

parameters <- names(al_design)
describe <- function(step) {
  fit <- step$fit
  s <- summary(fit)
  adequacy <- attr(s, "adequacy")
  draws <- as.data.frame(fit)
  keep <- match(parameters, s$parameter)
  tau <- s$estimate[s$parameter == "tau"]
  list(
    table = data.frame(parameter = parameters, mean = s$estimate[keep],
                       sd = vapply(parameters, function(p) stats::sd(draws[[p]]), numeric(1)),
                       lower = s$lower[keep], upper = s$upper[keep],
                       resolution = s$resolution[keep], row.names = NULL),
    adequacy = adequacy$parameters[c("parameter", "effective_values", "limited",
                                     "mass_at_min", "mass_at_max")],
    effective_runs = adequacy$effective_runs,
    runs = attr(adequacy$parameters, "runs")[c("effective_runs", "needed", "pareto_k",
                                               "k_threshold", "resolved")],
    # the noise sd the fit finds, in SEPIA's observation sds (1 / sqrt(E tau))
    noise_scale = 1 / sqrt(tau),
    emulation_error = fit$refinement$emulation_error,
    refinement = fit$refinement[c("runs_added", "rounds", "reason", "source")],
    n_runs = length(fit$exact$run),
    conditions = step$conditions, seconds = step$seconds, load = step$load,
    print = utils::capture.output(print(s)))
}
griddy <- lapply(list(base = base, stage1 = stage1, stage2 = stage2), describe)

# how far the data sit from the runs: the root mean square over the 12
# outputs of the standardised residual (y - g) / sd, in SEPIA's observation
# sds, at the library's closest run, and at each fit's posterior predictive
# mean (predict(): the outputs at the drawn runs, averaged)
rms <- function(z) sqrt(mean(z^2))
library_rms <- apply((t(al_sim) - al_obs) / al_obs_sd, 2, rms)
best_run <- which.min(library_rms)
residual_best_run <- (al_obs - al_sim[best_run, ]) / al_obs_sd
residual_predictive <- lapply(list(base = base, stage1 = stage1, stage2 = stage2), function(st) {
  p <- predict(st$fit, ndraws = 200, seed = 1)
  (p$observed - p$mean) / al_obs_sd
})
closest <- c(library = min(library_rms), vapply(residual_predictive, rms, numeric(1)))

# ---- the reference ---------------------------------------------------------------
ref_file <- Sys.getenv("AL5083_REFERENCE", "")
if (nzchar(ref_file) && file.exists(ref_file)) {
  reference <- readRDS(ref_file)
  if (is.null(reference$importance$rounds)) {
    # an earlier result without the rounds of importance sampling: its chains,
    # then those
    reference <- al5083_reference(al_design, al_sim, al_obs, al_obs_sd,
                                  emulator_cache = Sys.getenv("AL5083_EMULATORS", ""),
                                  previous = reference)
    saveRDS(reference, ref_file)
  }
} else {
  reference <- al5083_reference(al_design, al_sim, al_obs, al_obs_sd,
                                emulator_cache = Sys.getenv("AL5083_EMULATORS", ""))
  if (nzchar(ref_file)) saveRDS(reference, ref_file)
}

# ---- the comparison, per parameter -------------------------------------------------
compare <- function(g, r) {
  r <- r[match(g$parameter, r$variable), ]
  r_lower <- r[["2.5%"]]
  r_upper <- r[["97.5%"]]
  overlap <- pmax(0, pmin(g$upper, r_upper) - pmax(g$lower, r_lower))
  data.frame(parameter = g$parameter,
             griddy_mean = g$mean, griddy_lower = g$lower, griddy_upper = g$upper,
             reference_mean = r$mean, reference_sd = r$sd,
             reference_lower = r_lower, reference_upper = r_upper,
             mean_difference_sds = (g$mean - r$mean) / r$sd,
             width_ratio = (g$upper - g$lower) / (r_upper - r_lower),
             overlap_share = overlap / (r_upper - r_lower),
             row.names = NULL)
}
comparison <- lapply(griddy, function(x) compare(x$table, reference$mcmc$summary))
comparison_importance <- lapply(griddy, function(x) {
  compare(x$table, reference$importance$summary)
})
comparison_emulator_variance <- compare(griddy$stage2$table,
                                        reference$mcmc_emulator_variance$summary)
# how far the posterior means moved between the refine() calls, in the
# later stage's posterior sds
moved <- data.frame(parameter = parameters,
                    stage1 = (griddy$stage1$table$mean - griddy$base$table$mean) /
                      griddy$stage1$table$sd,
                    stage2 = (griddy$stage2$table$mean - griddy$stage1$table$mean) /
                      griddy$stage2$table$sd)
# the prior's sd of each parameter over the design's box, for scale
prior_sd <- vapply(al_design, function(v) diff(range(v)) / sqrt(12), numeric(1))

results <- list(
  made = format(Sys.time(), tz = "UTC", usetz = TRUE), session = R.version.string,
  sepia = list(commit = tryCatch(system2("git", c("--git-dir", shQuote(sepia_dir), "rev-parse",
                                                  "HEAD"), stdout = TRUE),
                                 warning = function(w) NA_character_)),
  data = list(n_runs = nrow(al_design), parameters = parameters, outputs = names(al_obs),
              obs = al_obs, obs_sd = al_obs_sd,
              range = vapply(al_design, range, numeric(2))),
  griddy = griddy, closest = closest, residual_best_run = residual_best_run,
  residual_predictive = residual_predictive,
  library_rms_quantiles = stats::quantile(library_rms, c(0, 0.01, 0.1, 0.5, 0.9, 1)),
  reference = reference[c("holdout", "emulator", "residual_at_mean", "emulator_sd_at_mean",
                          "settings", "seconds")],
  reference_mcmc = lapply(reference[c("mcmc", "mcmc_emulator_variance")], function(m) {
    m[c("summary", "acceptance", "starts")]
  }),
  reference_importance = reference$importance,
  comparison = comparison, comparison_importance = comparison_importance,
  comparison_emulator_variance = comparison_emulator_variance,
  moved = moved, prior_sd = prior_sd)
saveRDS(results, "inst/extdata/al5083.rds", compress = "xz")
str(results, max.level = 1)
print(comparison$stage2, digits = 3)
print(comparison_importance$stage2, digits = 3)
print(reference$importance[c("pareto_k", "ess", "n", "seconds")])
print(moved, digits = 3)
