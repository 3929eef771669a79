# Issue 33, item 2: one gap signal. A system griddy has not seen: a
# one-compartment drug concentration curve with first-order absorption,
#   C(t) = D k_a / (V (k_a - k_e)) (exp(-k_e t) - exp(-k_a t)),  V = 1,
# at three doses D = 1, 2, 4 (the x setting), 24 times from 0.25 to 12 h,
# theta = (k_a, k_e) on a 101 x 151 grid fine enough to resolve the posterior
# (so calibrate() gives no resolution warning and its gap screen speaks).
# Field data: one experiment (no replicates), noise sd 0.05, theta drawn in
# the middle half of the grid's box; in the gap
# trials a local second peak (reabsorption: a Gaussian bump at t = 6 h, sd
# 0.5 h) of 3 or 5 noise sds at the middle dose only. 15 trials per
# gap size, 45 without a gap; each counts calibrate()'s gap warning (class
# griddy_warning_gap; its block checks scan windows of every width at
# half-steps), the rule before the block checks (screen bound > log 20, from
# the same screen), what the fixed tiling of 8 windows per setting that the
# scan replaced would have flagged on the same fit (with the evidence rule),
# and diagnose_gap(fit)'s verdict "other".
#
# Run from the package root: Rscript bench/gap-signal.R [trials [levels]]
# (~5-15 s per trial on a loaded machine, ~8 min in all). Results: bench/results/gap-signal.csv.
pkgload::load_all(".", quiet = TRUE)
args <- commandArgs(trailingOnly = TRUE)
n_trials <- if (length(args) >= 1L) as.integer(args[1]) else 15L

times <- seq(0.25, 12, length.out = 24)
doses <- data.frame(dose = c(1, 2, 4))
conc <- function(ka, ke) {
  unlist(lapply(doses$dose, function(D) D * ka / (ka - ke) * (exp(-ke * times) - exp(-ka * times))))
}
theta <- expand.grid(k_a = seq(1.3, 1.7, length.out = 101),
                     k_e = seq(0.185, 0.215, length.out = 151))
Y <- t(mapply(conc, theta$k_a, theta$k_e))
library_pk <- sim_library(theta, Y, x = doses, t = times)
noise_sd <- 0.05

# One trial's field data `y` and its truth (`ka`, `ke`): a truth drawn inside the library, a Gaussian
# second peak of `size` noise sds at t = 6 h at the middle dose, noise.
trial_data <- function(size, seed) {
  set.seed(seed)
  ka <- stats::runif(1, 1.4, 1.6)
  ke <- stats::runif(1, 0.1925, 0.2075)
  y <- matrix(conc(ka, ke), 3, length(times), byrow = TRUE)
  y[2, ] <- y[2, ] + size * noise_sd * exp(-0.5 * ((times - 6) / 0.5)^2)
  y <- y + stats::rnorm(length(y), sd = noise_sd)
  list(y = y, ka = ka, ke = ke)
}

# A fit with a discrepancy (calibrate(discrepancy = gp_discrepancy())) on the
# same trials (15 without a gap, 15 at 5 sds): its gap warning, which counts
# the block checks of its model without the discrepancy, against its
# evidence alone (the warning before). Rscript bench/gap-signal.R 15
# discrepancy (~3 min; only this); results in
# bench/results/gap-signal-discrepancy.csv.
if (length(args) >= 2L && args[2] == "discrepancy") {
  dr <- list()
  for (size in c(0, 5)) {
    for (i in seq_len(n_trials)) {
      seed <- 1000L * size + i
      classes <- character(0)
      fit <- withCallingHandlers(
        calibrate(library_pk, field_data(trial_data(size, seed)$y, x = doses, t = times),
                  n_iter = 1000, burn_in = 200, seed = seed, discrepancy = gp_discrepancy()),
        warning = function(w) {
          classes <<- c(classes, class(w)[1])
          invokeRestart("muffleWarning")
        })
      lbf <- discrepancy_evidence(fit)$log_bayes_factor
      dr[[length(dr) + 1L]] <- data.frame(size = size, seed = seed, log_bf = lbf,
                                          flagged = fit$gap_screen$n_flagged,
                                          warned = "griddy_warning_gap" %in% classes,
                                          evidence_alone = gap_shown(lbf))
      message(sprintf("discrepancy fit, size %g seed %d: warned %s (log BF %.2f, %d blocks)",
                      size, seed, dr[[length(dr)]]$warned, lbf, fit$gap_screen$n_flagged))
    }
  }
  dr <- do.call(rbind, dr)
  utils::write.csv(dr, "bench/results/gap-signal-discrepancy.csv", row.names = FALSE)
  print(stats::aggregate(cbind(warned, evidence_alone) ~ size, dr, sum))
  quit(save = "no")
}

trial <- function(size, seed) {
  data <- trial_data(size, seed)
  ka <- data$ka
  ke <- data$ke
  field <- field_data(data$y, x = doses, t = times)
  classes <- character(0)
  start <- proc.time()[["elapsed"]]
  fit <- withCallingHandlers(
    calibrate(library_pk, field, n_iter = 1000, burn_in = 200, seed = seed),
    warning = function(w) {
      classes <<- c(classes, class(w)[1])
      invokeRestart("muffleWarning")
    })
  t_fit <- proc.time()[["elapsed"]] - start
  start <- proc.time()[["elapsed"]]
  dg <- suppressWarnings(diagnose_gap(fit, seed = seed))
  t_dg <- proc.time()[["elapsed"]] - start
  screen <- fit$gap_screen
  tiling <- base_check(fit, 8L, gap_block_fdr, screen_runs(fit$exact$run))$blocks
  data.frame(size = size, seed = seed, k_a = ka, k_e = ke,
             warned = "griddy_warning_gap" %in% classes,
             resolution_warned = "griddy_warning_resolution" %in% classes,
             old_rule = isTRUE(screen$log_bf > log(20)) && screen_shows_gap(fit),
             screen_log_bf = if (is.null(screen)) NA else screen$log_bf,
             screen_flagged = if (is.null(screen)) NA else screen$n_flagged,
             tiling_warns = gap_shown(screen$log_bf, sum(tiling$flagged)) &&
               !"griddy_warning_resolution" %in% classes,
             dg_answer = dg$verdict$answer, dg_reason = dg$verdict$reason,
             dg_log_bf = dg$evidence$log_bayes_factor,
             dg_other = dg$verdict$answer == "other",
             seconds_calibrate = t_fit, seconds_diagnose = t_dg)
}

rows <- list()
for (size in c(0, 3, 5)) {
  # three times as many trials without a gap: the false-alarm rate is the
  # number that must stay small
  for (i in seq_len(if (size == 0) 3L * n_trials else n_trials)) {
    rows[[length(rows) + 1L]] <- trial(size, 1000L * size + i)
    r <- rows[[length(rows)]]
    message(sprintf("size %g seed %d: warned %s (bound %.2f, %d blocks) diagnose_gap %s/%s",
                    size, r$seed, r$warned, r$screen_log_bf, r$screen_flagged, r$dg_answer,
                    r$dg_reason))
  }
}
out <- do.call(rbind, rows)
dir.create("bench/results", showWarnings = FALSE)
utils::write.csv(out, "bench/results/gap-signal.csv", row.names = FALSE)
tab <- do.call(rbind, lapply(split(out, out$size), function(d) {
  data.frame(size_sd = d$size[1], trials = nrow(d), calibrate_warns = sum(d$warned),
             old_rule_warns = sum(d$old_rule), tiling_warns = sum(d$tiling_warns),
             diagnose_gap_other = sum(d$dg_other),
             disagree = sum(d$warned != d$dg_other),
             resolution_warned = sum(d$resolution_warned))
}))
print(tab, row.names = FALSE)

# The block checks' level (gap_block_fdr): calibrate() only, more seeds (90
# without a gap, 30 at 3 sds, 45 at 5 sds), each trial's screen bound and
# smallest Benjamini-Hochberg adjusted p-value, so that the warning's rate
# can be read at any level. Rscript bench/gap-signal.R 15 levels (~2 min);
# results in bench/results/gap-signal-levels.csv.
if (length(args) >= 2L && args[2] == "levels") {
  lv <- list()
  for (size in c(0, 3, 5)) {
    seeds <- switch(as.character(size), "0" = c(1:45, 101:145), "3" = 3001:3030,
                    "5" = 5001:5045)
    for (seed in seeds) {
      y <- trial_data(size, seed)$y
      fit <- suppressWarnings(calibrate(library_pk, field_data(y, x = doses, t = times),
                                        n_iter = 1000, burn_in = 200, seed = seed))
      b <- fit$gap_screen$blocks
      tiling <- base_check(fit, 8L, gap_block_fdr, screen_runs(fit$exact$run))$blocks
      lv[[length(lv) + 1L]] <- data.frame(
        size = size, seed = seed, bound = fit$gap_screen$log_bf,
        min_adj = min(stats::p.adjust(b$p_value, "BH")),
        tiling_min_adj = min(stats::p.adjust(tiling$p_value, "BH")))
    }
  }
  lv <- do.call(rbind, lv)
  utils::write.csv(lv, "bench/results/gap-signal-levels.csv", row.names = FALSE)
  for (q in c(0.05, 0.025, 0.01)) {
    rate <- tapply(lv$bound > gap_detect_log_odds | lv$min_adj <= q, lv$size, mean)
    cat("block level", q, ": warned share by size", names(rate), ":", round(rate, 3), "\n")
    rate <- tapply(lv$bound > gap_detect_log_odds | lv$tiling_min_adj <= q, lv$size, mean)
    cat("  (the fixed tiling:", round(rate, 3), ")\n")
  }
}
