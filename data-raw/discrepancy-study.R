# What a discrepancy can and cannot promise: a study on a damped oscillator
# with field data from a simulator that misses (a hardening spring, which a
# stiffer linear spring partly imitates; an additive local bump, which no
# theta imitates) or does not (no gap), each with one experiment or three
# replicated ones. Each trial, through the documented API only: calibrate()
# without a discrepancy and with gp_discrepancy() in four forms (the default
# orthogonal GaSP, a plain GaSP, the scaled S-GaSP of Gu and Wang 2018 and
# the orthogonal S-GaSP), the log Bayes factor (discrepancy_evidence()),
# logLik(), diagnose_gap(fit) without candidates ($which, $where), and the
# 95% intervals of theta against the truth. Run from the package root:
#   Rscript data-raw/discrepancy-study.R
# (15 minutes on a shared 2-core machine; DISC_STUDY_TRIALS=2 runs 2 trials
# per arm instead of 10, and overwrites the CSV too.)
# Results: inst/extdata/discrepancy_study.csv (one row per trial and fit):
# the arm (gap, reps), trial, seed, true w and c; diagnose_gap() on the fit
# without a discrepancy (diagnosis = top of $which, prob_other, n_flagged
# blocks of $where, those on the bump's windows and at the largest
# amplitude); and per fit (none, orthogonal, gasp, sgasp, orthogonal_sgasp)
# logLik (loglik_none: without a discrepancy), log_bayes_factor, the 95%
# intervals of w and c, their posterior means and whether they cover.
pkgload::load_all(".", quiet = TRUE)

# The simulator: x = amplitude a, t = time; theta = (w, c) the linear
# spring's frequency and damping. Reality: a spring that hardens with
# amplitude (frequency w (1 + h a^2)) and/or an additive bump at the largest
# amplitude around t = 1.2 (height `bump`).
amps <- c(0.5, 1, 1.5)
times <- seq(0, 2, length.out = 25)
oscillator <- function(w, c, h = 0, bump = 0) {
  unlist(lapply(amps, function(a) {
    a * exp(-c * times) * cos(w * (1 + h * a^2) * times) +
      bump * (a == 1.5) * exp(-((times - 1.2) / 0.15)^2)
  }))
}
bump_region <- function(x, from, to) x == 3 & to >= 1.0 & from <= 1.4

# The library: a fine grid of runs (spacing 0.02 in w, 0.01 in c). The true
# theta is drawn among its runs (w in [6, 6.6], c in [0.7, 1]), so that the
# coverage measures what the discrepancy does, not the runs' spacing (for a
# truth between runs see vignette("between-the-runs")).
theta_grid <- expand.grid(w = seq(5.8, 7.4, by = 0.02), c = seq(0.6, 1.15, by = 0.01))
# values taken from the grid itself, so that a truth equals its run exactly
candidate_w <- unique(theta_grid$w[theta_grid$w > 5.99 & theta_grid$w < 6.61])
candidate_c <- unique(theta_grid$c[theta_grid$c > 0.69 & theta_grid$c < 1.01])
library <- sim_library(theta_grid, t(mapply(oscillator, theta_grid$w, theta_grid$c)),
                       x = data.frame(amp = amps), t = times)

gaps <- list(none = c(h = 0, bump = 0), hardening = c(h = 0.05, bump = 0),
             bump = c(h = 0, bump = 0.3))
kernels <- list(orthogonal = gp_discrepancy(),
                gasp = gp_discrepancy(orthogonal = FALSE),
                sgasp = gp_discrepancy(orthogonal = FALSE, scaled = TRUE),
                orthogonal_sgasp = gp_discrepancy(scaled = TRUE))
sd_noise <- 0.05
n_trials <- as.integer(Sys.getenv("DISC_STUDY_TRIALS", "10"))

one_trial <- function(gap, reps, trial) {
  seed <- 1000 * match(gap, names(gaps)) + 100 * reps + trial
  set.seed(seed)
  truth <- c(w = sample(candidate_w, 1), c = sample(candidate_c, 1))
  mu <- oscillator(truth[["w"]], truth[["c"]], gaps[[gap]][["h"]], gaps[[gap]][["bump"]])
  y <- do.call(rbind, lapply(seq_len(reps), function(r) {
    matrix(mu + stats::rnorm(length(mu), 0, sd_noise), length(amps), length(times), byrow = TRUE)
  }))
  field <- field_data(y, x = data.frame(amp = rep(amps, reps)), t = times)
  quiet <- function(expr) suppressWarnings(expr)
  fit <- function(discrepancy) {
    quiet(calibrate(library, field, n_iter = 3000, burn_in = 500, seed = seed,
                    discrepancy = discrepancy))
  }
  plain <- fit(NULL)
  diagnosis <- quiet(diagnose_gap(plain, seed = seed))
  where <- diagnosis$where[diagnosis$where$flagged, ]
  top <- diagnosis$which$effect[1]
  common <- data.frame(
    gap = gap, reps = reps, trial = trial, seed = seed,
    w_true = truth[["w"]], c_true = truth[["c"]],
    diagnosis = top,
    prob_other = diagnosis$which$prob[diagnosis$which$effect == "other"],
    n_flagged = nrow(where),
    flagged_in_bump = sum(bump_region(where$x, where$from, where$to)),
    flagged_largest_amp = sum(where$x == 3),
    loglik_none = as.numeric(logLik(plain)))
  rows <- lapply(c("none", names(kernels)), function(k) {
    f <- if (k == "none") plain else fit(kernels[[k]])
    ci <- stats::confint(f)
    ev <- if (k == "none") NA_real_ else discrepancy_evidence(f)$log_bayes_factor
    data.frame(common, fit = k,
               loglik = as.numeric(logLik(f)), log_bayes_factor = ev,
               w_lo = ci["w", 1], w_hi = ci["w", 2], c_lo = ci["c", 1], c_hi = ci["c", 2],
               w_mean = stats::coef(f)[["w"]], c_mean = stats::coef(f)[["c"]])
  })
  do.call(rbind, rows)
}

arms <- expand.grid(trial = seq_len(n_trials), reps = c(1L, 3L), gap = names(gaps),
                    stringsAsFactors = FALSE)
started <- Sys.time()
results <- do.call(rbind, lapply(seq_len(nrow(arms)), function(i) {
  one_trial(arms$gap[i], arms$reps[i], arms$trial[i])
}))
message("study time: ", format(Sys.time() - started, digits = 3))
results$w_covered <- results$w_lo <= results$w_true & results$w_true <= results$w_hi
results$c_covered <- results$c_lo <= results$c_true & results$c_true <= results$c_hi
num <- vapply(results, is.double, TRUE)
results[num] <- lapply(results[num], signif, digits = 6)
utils::write.csv(results, "inst/extdata/discrepancy_study.csv", row.names = FALSE)
