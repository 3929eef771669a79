# The thesis's open question (issue 24 item 4): how do the runs needed, the
# time and the coverage grow with the number of unknown parameters, for a
# plain fit on a Latin hypercube library and for refine()?
#
# System: smooth-p of bench/many-parameters-systems.R (80 data points, noise
# sd 0.05, the last two of p >= 6 parameters weakly identified), p = 2, 3,
# 4, 6, 8, 10, 12, trials 1 to 10 (truth, noise and reference as in
# bench/many-parameters.R; calibrate() and refine() with seed = trial).
#
# Plain fits: Latin hypercube libraries of N = 500, 2,000, 8,000, 32,000 and
# 128,000 runs (each `set.seed(2024); lhs(N)`: the 2,000 one is
# many-parameters.R's library, shared by the trials). For each trial the
# ladder stops at the first N whose fit is resolved by griddy's own test
# (resolution_limited(): from four parameters max(100, 20 p) effective runs
# and a Pareto k-hat below its threshold, R/resolution-runs.R; below four, 10
# effective values per parameter, R/resolution.R) and has at least
# max(100, 20 p) effective runs (at p >= 4 implied by the first; at p = 2, 3
# the ladder goes on past the weaker test so that the run target can be
# compared at every p), or at 128,000 (512,000 at p = 2, where the measured
# effective runs are many enough to check the extrapolation below).
#
# Extrapolation (a Gaussian approximation, not a measurement): under a
# uniform prior on the unit box, a plain library of N runs weighs run i by
# the posterior density pi(theta_i), so its effective runs (Kish) are about
# N / int pi^2; with pi ~ N(mu, Sigma), int pi^2 = 1 / ((4 pi)^(p/2)
# |Sigma|^(1/2)). Sigma is the reference's weighted covariance (theta is
# already in unit coordinates). The runs needed for the target max(100, 20 p)
# are then target / ((4 pi)^(p/2) |Sigma|^(1/2)) (`extrapolated_runs_needed`),
# and for griddy's own test (10 effective runs at p = 2, 3)
# `extrapolated_runs_resolved`; `predicted_effective_runs`
# is N (4 pi)^(p/2) |Sigma|^(1/2) at each rung, to check against the measured.
#
# Refinement: refine(fit on the 2,000-run library, simulator, max_runs =
# 20000); for p >= 10, again with 40000 when 20000 ran out (both rows kept).
#
# Run: Rscript bench/many-parameters-scaling.R [ps] [trials] [name]
#   e.g. Rscript bench/many-parameters-scaling.R 2,3,4,6,8,10,12 10 (the defaults)
# writes bench/results/<name>.csv (one row per trial x parameter x stage; a
# plain stage per rung) and bench/results/<name>.md (the summaries), name
# many-parameters-scaling by default.
args <- commandArgs(trailingOnly = TRUE)
ps <- if (length(args) >= 1) as.integer(strsplit(args[1], ",")[[1]]) else c(2L, 3L, 4L, 6L, 8L, 10L, 12L)
n_trials <- if (length(args) >= 2) as.integer(args[2]) else 10L
out_name <- if (length(args) >= 3) args[3] else "many-parameters-scaling"
pkgload::load_all(".", quiet = TRUE)
source("bench/many-parameters-systems.R")
library(data.table)

ladder <- c(500L, 2000L, 8000L, 32000L, 128000L)
# at p = 2 one rung more, 512,000, to check the Gaussian prediction where the
# measured effective runs are many (at p >= 3 they stay near 1 up to 128,000)
ladder_for <- function(p) if (p == 2L) c(ladder, 512000L) else ladder
refine_max_runs <- 20000L
refine_max_runs_large <- 40000L # p >= 10, when 20,000 ran out

run_target <- function(p) effective_runs_needed(p)
# griddy's own test in effective runs: below four parameters 10 effective
# values per parameter, which in a Latin hypercube (a value per run) are its
# effective runs
resolved_target <- function(p) {
  if (p >= proposal_min_parameters) effective_runs_needed(p) else resolution_min_values
}

# Effective runs per library run of a plain library under the Gaussian
# approximation: (4 pi)^(p/2) |Sigma|^(1/2)
gaussian_effective_fraction <- function(Sigma) {
  p <- nrow(Sigma)
  exp(p / 2 * log(4 * pi) + 0.5 * as.numeric(determinant(Sigma, logarithm = TRUE)$modulus))
}

load_note <- function() paste(round(load_average(), 2), collapse = " ")

# One stage's rows (one per parameter)
stage_rows <- function(tab, d, stage, library_runs) {
  ref <- d$ref
  data.table(stage = stage, library_runs = library_runs, parameter = tab$parameter,
             truth = d$truth, lower = tab$lower, upper = tab$upper,
             covered = tab$lower <= d$truth & d$truth <= tab$upper,
             ref_lower = ref$lower, ref_upper = ref$upper,
             ref_covered = ref$lower <= d$truth & d$truth <= ref$upper,
             width_ratio = (tab$upper - tab$lower) / (ref$upper - ref$lower),
             effective_runs = tab$effective_runs, pareto_k = tab$pareto_k,
             effective_values = tab$effective_values,
             resolved = !any(tab$limited & !tab$constant))
}

# The extrapolation's one approximation is int pi^2 ~ 1 / ((4 pi)^(p/2)
# |Sigma|^(1/2)) (and a Latin hypercube ~ independent uniform runs). At p >= 3
# the plain ladder cannot check it (its effective runs stay near 1), so each
# trial also fits a 128,000-run Latin hypercube over the box B of the
# reference's mean +- 3 marginal sds (clipped to the range): there the
# same reasoning predicts N m^2 (4 pi)^(p/2) |Sigma|^(1/2) / |B| effective
# runs, with m the posterior mass in B (taken as prod(2 Phi(3) - 1) over
# the parameters not clipped), which is many at every p (at +- 3.5 sds p = 12
# predicted only 17, too few for a stable count).
local_runs <- 128000L
local_half_width <- 3
local_check <- function(sys, i, d, fraction) {
  p <- length(sys$lower)
  sd <- sqrt(diag(d$ref$cov))
  lo <- pmax(sys$lower, d$ref$mean - local_half_width * sd)
  hi <- pmin(sys$upper, d$ref$mean + local_half_width * sd)
  clipped <- lo == sys$lower | hi == sys$upper
  mass <- prod((2 * stats::pnorm(local_half_width) - 1)^(!clipped))
  set.seed(2024)
  theta <- lhs(local_runs, lo, hi, sys$names)
  lib <- sim_library(theta, sys$sim(theta))
  gc()
  ct <- calibrate_timed(lib, d$field, i)
  fit <- ct$fit
  secs <- ct$seconds
  tab <- resolution_limited(fit)
  predicted <- local_runs * mass^2 * fraction / prod(hi - lo)
  row <- stage_rows(tab, d, "local", local_runs)
  row[, `:=`(warned = ct$warned, seconds = secs, simulator_seconds = NA_real_,
             runs_added = NA_integer_, reason = NA_character_, max_runs = NA_integer_,
             predicted_effective_runs = predicted, load = load_note())]
  message(sprintf("p %d trial %d local box N %d: %.1f effective runs (predicted %.1f)",
                  p, i, local_runs, row$effective_runs[1], predicted))
  row
}

# calibrate() as the trials call it: list(fit, warned (its resolution
# warning), seconds); other warnings are muffled as before
calibrate_timed <- function(lib, field, i) {
  warned <- FALSE
  t0 <- proc.time()[["elapsed"]]
  fit <- withCallingHandlers(
    calibrate(lib, field, n_iter = 1000, burn_in = 200, seed = i),
    warning = function(w) {
      if (inherits(w, "griddy_warning_resolution")) warned <<- TRUE
      invokeRestart("muffleWarning")
    })
  list(fit = fit, warned = warned, seconds = proc.time()[["elapsed"]] - t0)
}

scaling_trial <- function(sys, i, libs) {
  p <- length(sys$lower)
  d <- trial_data(sys, i, libs[["2000"]])
  fraction <- gaussian_effective_fraction(d$ref$cov)
  target <- run_target(p)
  fits <- list()
  rows <- list()
  for (n in ladder_for(p)) {
    lib <- libs[[as.character(n)]]
    gc()
    ct <- calibrate_timed(lib, d$field, i)
    fit <- ct$fit
    secs <- ct$seconds
    tab <- resolution_limited(fit)
    row <- stage_rows(tab, d, "plain", n)
    row[, `:=`(warned = ct$warned, seconds = secs, simulator_seconds = NA_real_,
               runs_added = NA_integer_, reason = NA_character_, max_runs = NA_integer_,
               predicted_effective_runs = n * fraction, load = load_note())]
    rows[[length(rows) + 1L]] <- row
    if (n == 2000L) fits[["2000"]] <- fit
    message(sprintf("p %d trial %d plain N %d: %.1f effective runs (predicted %.1f), resolved %s, %.1f s",
                    p, i, n, row$effective_runs[1], n * fraction, row$resolved[1], secs))
    if (row$resolved[1] && row$effective_runs[1] >= target) break
  }
  rows[[length(rows) + 1L]] <- local_check(sys, i, d, fraction)
  fit <- fits[["2000"]]
  if (is.null(fit)) {
    fit <- calibrate_timed(libs[["2000"]], d$field, i)$fit
  }
  attempt <- function(max_runs) {
    gc()
    rt <- refine_timed(fit, sys, max_runs, seed = i, label = paste0("p ", p, " trial ", i))
    r <- rt$fit
    added <- if (is.null(r$refinement)) 0L else r$refinement$runs_added
    reason <- if (is.null(r$refinement)) "resolved" else r$refinement$reason
    row <- stage_rows(resolution_limited(r), d, "refine", 2000L + added)
    row[, `:=`(warned = rt$warned, seconds = rt$seconds, simulator_seconds = rt$simulator_seconds,
               runs_added = added, reason = reason, max_runs = max_runs,
               predicted_effective_runs = NA_real_, load = load_note())]
    message(sprintf("p %d trial %d refine (max_runs %d): %d runs added, %s, %.1f effective runs, %.1f s",
                    p, i, max_runs, added, reason, row$effective_runs[1], rt$seconds))
    row
  }
  rows[[length(rows) + 1L]] <- attempt(refine_max_runs)
  if (p >= 10 && rows[[length(rows)]]$reason[1] == "max_runs") {
    rows[[length(rows) + 1L]] <- attempt(refine_max_runs_large)
  }
  out <- rbindlist(rows)
  out[, `:=`(p = p, trial = i, target_effective_runs = target,
             gaussian_fraction = fraction, extrapolated_runs_needed = target / fraction,
             resolved_target = resolved_target(p),
             extrapolated_runs_resolved = resolved_target(p) / fraction,
             ref_ess = d$ref$ess, log_det_sigma = as.numeric(
               determinant(d$ref$cov, logarithm = TRUE)$modulus))]
  setcolorder(out, c("p", "trial", "stage", "library_runs", "parameter"))
  out
}

t_start <- proc.time()[["elapsed"]]
uptime_start <- system("uptime", intern = TRUE)
res <- rbindlist(lapply(ps, function(p) {
  sys <- smooth_system(p)
  # the libraries, built once per p and shared by the trials
  libs <- list()
  for (n in ladder_for(p)) libs[[as.character(n)]] <- lhs_library(sys, n)
  out <- rbindlist(lapply(seq_len(n_trials), function(i) scaling_trial(sys, i, libs)))
  rm(libs); gc()
  out
}))
total_minutes <- (proc.time()[["elapsed"]] - t_start) / 60
uptime_end <- system("uptime", intern = TRUE)

dir.create("bench/results", showWarnings = FALSE)
fwrite(res, file.path("bench/results", paste0(out_name, ".csv")))

# ---- summaries ---------------------------------------------------------------
# runs as text: commas below 10^7, else 3.0e+24
fmt_runs <- function(x) {
  ifelse(is.na(x), "",
         ifelse(x < 1e7, formatC(signif(x, 3), format = "d", big.mark = ","),
                formatC(x, digits = 1, format = "e")))
}
range_runs <- function(x) {
  if (signif(min(x), 3) == signif(max(x), 3)) fmt_runs(min(x)) else
    paste0(fmt_runs(min(x)), "-", fmt_runs(max(x)))
}
range_num <- function(x, digits = 2) {
  a <- formatC(min(x), digits = digits, format = "fg")
  b <- formatC(max(x), digits = digits, format = "fg")
  if (a == b) a else paste0(a, "-", b)
}
pct <- function(x) sprintf("%.0f%%", 100 * mean(x))

# per trial and stage (the parameters share a stage's runs, flags and time)
per_trial <- res[, .(effective_runs = effective_runs[1], pareto_k = pareto_k[1],
                     resolved = resolved[1], warned = warned[1], seconds = seconds[1],
                     simulator_seconds = simulator_seconds[1], runs_added = runs_added[1],
                     reason = reason[1], predicted_effective_runs = predicted_effective_runs[1],
                     coverage = mean(covered), ref_coverage = mean(ref_covered),
                     missed_unwarned = sum(!covered & !warned),
                     missed_unwarned_ref_covered = sum(!covered & !warned & ref_covered),
                     median_width_ratio = median(width_ratio),
                     extrapolated_runs_needed = extrapolated_runs_needed[1],
                     extrapolated_runs_resolved = extrapolated_runs_resolved[1],
                     target = target_effective_runs[1]),
                 by = .(p, trial, stage, library_runs, max_runs)]
plain <- per_trial[stage == "plain"]
# the final refine() per trial (40,000 when 20,000 ran out at p >= 10)
refined <- per_trial[stage == "refine"][order(p, trial, max_runs)][, .SD[.N], by = .(p, trial)]

# the first rung resolved by griddy's test, and the first with the run target
first_rung <- function(ok, n) if (any(ok)) min(n[ok]) else NA_integer_
plain_needed <- plain[, .(resolved_at = first_rung(resolved, library_runs),
                          target_at = first_rung(effective_runs >= target & resolved, library_runs),
                          largest_rung = max(library_runs),
                          effective_runs_largest = effective_runs[which.max(library_runs)],
                          predicted_largest = predicted_effective_runs[which.max(library_runs)],
                          extrapolated_resolved = extrapolated_runs_resolved[1],
                          extrapolated_target = extrapolated_runs_needed[1]), by = .(p, trial)]
rung_text <- function(at, largest) ifelse(is.na(at), paste0("> ", fmt_runs(largest)), fmt_runs(at))
# "128,000 (10 trials)"; rungs in increasing order
rung_counts <- function(at, largest) {
  key <- ifelse(is.na(at), largest + 0.5, at)
  txt <- rung_text(at, largest)
  o <- order(key)
  tab <- table(factor(txt[o], levels = unique(txt[o])))
  paste0(names(tab), " (", as.integer(tab), ")", collapse = ", ")
}

# the Gaussian prediction against the measured effective runs, where the
# measured count is at least 10 (below it a few runs carry the posterior:
# the best run alone counts as one, whatever the prediction)
check <- plain[effective_runs >= 10, .(p, trial, library_runs, effective_runs,
                                       predicted_effective_runs,
                                       ratio = effective_runs / predicted_effective_runs)]

local <- per_trial[stage == "local"][, ratio := effective_runs / predicted_effective_runs][]

by_p <- merge(
  plain_needed[, .(resolved_at = rung_counts(resolved_at, largest_rung),
                   target_at = rung_counts(target_at, largest_rung),
                   extrapolated_resolved = range_runs(extrapolated_resolved),
                   extrapolated_target = range_runs(extrapolated_target)), by = p],
  refined[, .(trials = .N, runs_added = range_runs(runs_added),
              reasons = paste(unique(reason), collapse = ", "),
              max_runs = paste(unique(max_runs), collapse = ", "),
              refine_seconds = range_num(seconds),
              ms_outside_per_run = range_num(1000 * (seconds - simulator_seconds) /
                                               pmax(runs_added, 1L)),
              refine_effective_runs = range_num(effective_runs, 3),
              warned = sum(warned), missed_unwarned = sum(missed_unwarned),
              missed_unwarned_ref_covered = sum(missed_unwarned_ref_covered)), by = p],
  by = "p")
stage_label <- function(stage, n) ifelse(stage == "plain", paste0("plain ", fmt_runs(n)), "refine")
# refine()'s rows: the final attempt of each trial
final <- res[, keep := stage == "plain" | max_runs %in% max(max_runs[stage == "refine"]),
             by = .(p, trial)][keep == TRUE][, keep := NULL]
res[, keep := NULL]
final[, label := factor(stage_label(stage, library_runs),
                        levels = c(paste0("plain ", fmt_runs(sort(unique(c(ladder, 512000L))))),
                                   "refine"))]
coverage_p <- final[, .(coverage = mean(covered), ref_coverage = mean(ref_covered),
                        median_width_ratio = median(width_ratio)), by = .(p, stage, label)]
wide <- function(value, f) {
  w <- dcast(coverage_p, p ~ label, value.var = value, drop = TRUE)
  cols <- setdiff(names(w), "p")
  w[, (cols) := lapply(.SD, function(x) ifelse(is.na(x), "", f(x))), .SDcols = cols]
  w
}

# growth: log(runs) against log(p) (a power law), log(runs) against p
# (exponential), runs against p (linear)
growth <- function(runs, p, what) {
  power <- lm(log(runs) ~ log(p))
  expo <- lm(log(runs) ~ p)
  linear <- lm(runs ~ p)
  data.table(what = what, p = paste0(min(p), "-", max(p)),
             power_law_slope = coef(power)[[2]], power_law_r2 = summary(power)$r.squared,
             factor_per_parameter = exp(coef(expo)[[2]]), exponential_r2 = summary(expo)$r.squared,
             runs_per_parameter = coef(linear)[[2]], linear_r2 = summary(linear)$r.squared)
}
refine_med <- refined[, .(runs_added = median(runs_added), total = median(2000 + runs_added)), by = p]
plain_med <- plain_needed[, .(resolved = median(extrapolated_resolved),
                              target = median(extrapolated_target)), by = p]
growth_tab <- rbind(
  growth(refine_med$runs_added, refine_med$p, "refine(): runs added"),
  refine_med[p >= 4, growth(runs_added, p, "refine(): runs added (proposal rounds, p >= 4)")],
  growth(refine_med$total, refine_med$p, "refine(): library runs in all (2,000 + added)"),
  growth(plain_med$resolved, plain_med$p, "plain: runs to resolve, Gaussian extrapolation"),
  growth(plain_med$target, plain_med$p, "plain: runs for max(100, 20 p), Gaussian extrapolation"))
growth_tab[startsWith(what, "plain"), `:=`(runs_per_parameter = NA_real_, linear_r2 = NA_real_)]
# the plain extrapolation's factor per added parameter, between successive p
plain_steps <- plain_med[order(p)][, .(from = shift(p), to = p,
                                       factor_per_parameter = exp(diff(c(NA, log(resolved))) /
                                                                    diff(c(NA, p))))][-1]

kable <- function(x, digits = 3) paste(knitr::kable(x, format = "pipe", digits = digits), collapse = "\n")
md <- c(
  "# Many parameters: how runs, time and coverage grow with p (issue 24 item 4)",
  "",
  paste0("`Rscript bench/many-parameters-scaling.R ", paste(ps, collapse = ","), " ", n_trials,
         "` on ", format(Sys.time(), "%Y-%m-%d %H:%M %Z"), ", ", R.version.string, ". ",
         "Total ", sprintf("%.1f", total_minutes), " min. `uptime` at the start: ",
         trimws(sub(".*load", "load", uptime_start)), "; at the end: ",
         trimws(sub(".*load", "load", uptime_end)), " (2 cores shared with other jobs: times ",
         "are noisy). Each row's load average is in the CSV's `load` column."),
  "",
  "System smooth-p (bench/many-parameters-systems.R): 80 data points, noise sd 0.05, theta in",
  "[0, 1]^p, the last two of p >= 6 parameters weakly identified. Reference: importance sampling",
  "with the exact simulator (40,000 t draws). Every CSV row is one trial x parameter x stage.",
  "",
  "## Runs needed, per p",
  "",
  "Plain: `resolved at` lists, per trial, the first rung of the ladder (Latin hypercubes of",
  "500, 2,000, 8,000, 32,000, 128,000 runs; 512,000 too at p = 2) whose fit griddy's own test",
  "calls resolved (from p = 4: max(100, 20 p) effective runs and a Pareto k-hat below its",
  "threshold; at p = 2, 3: 10 effective values per parameter, in a Latin hypercube 10 effective",
  "runs); `target at` the first that also has max(100, 20 p) effective runs (the same rung from",
  "p = 4). `extrapolated` are the Gaussian approximation's runs for griddy's test (`resolve`)",
  "and for max(100, 20 p) effective runs (`target`), ranges over the trials: extrapolations, not",
  "measurements. refine() starts from the 2,000-run library; `ms outside` is refine()'s time",
  "outside the simulator per added run.",
  "",
  kable(by_p[, .(p, trials, `plain: resolved at` = resolved_at, `plain: target at` = target_at,
                 `extrapolated: resolve` = extrapolated_resolved,
                 `extrapolated: target` = extrapolated_target,
                 `refine: runs added` = runs_added, reason = reasons, max_runs,
                 `effective runs` = refine_effective_runs, `refine s` = refine_seconds,
                 `ms outside` = ms_outside_per_run, warned,
                 `missed unwarned (ref covers)` = paste0(missed_unwarned, " (",
                                                        missed_unwarned_ref_covered, ")"))]),
  "",
  "## Coverage and width against the reference, per p and stage",
  "",
  "Coverage over trial x parameter pairs (a plain rung counts only the trials that reached it):",
  "",
  kable(wide("coverage", function(x) sprintf("%.0f%%", 100 * x))),
  "",
  "Median width / reference:",
  "",
  kable(wide("median_width_ratio", function(x) sprintf("%.2f", x))),
  "",
  with(final[stage == "refine" & !covered & ref_covered],
       paste0("refine()'s misses where the reference covers: ", length(p), ", the truth at most ",
              sprintf("%.3f", max(0, pmax(lower - truth, truth - upper) / (upper - lower))),
              " of the interval's width outside it.")),
  "",
  paste0("The reference's own coverage: ",
         coverage_p[stage == "refine", paste0("p = ", p, " ", sprintf("%.0f%%", 100 * ref_coverage),
                                              collapse = ", ")], "."),
  "",
  "## Plain fits, per rung (medians over the trials that reached it)",
  "",
  paste0("calibrate()'s resolution warning fired on ", sum(plain$warned), " of ", nrow(plain),
         " plain fits; on ", sum(plain$warned == plain$resolved), " it disagreed with the",
         " resolved flag (resolution_limited())."),
  "",
  kable(plain[, .(trials = .N, effective_runs = median(effective_runs),
                  predicted = signif(median(predicted_effective_runs), 3),
                  resolved = sum(resolved), warned = sum(warned), coverage = pct(coverage),
                  calibrate_seconds = median(seconds)), by = .(p, N = library_runs)]),
  "",
  "## The Gaussian extrapolation against the measured effective runs",
  "",
  paste0("Rungs with at least 10 measured effective runs: ", nrow(check),
         if (nrow(check) > 0) paste0(" (p = ", paste(unique(check$p), collapse = ", "),
                                     "); measured / predicted: median ",
                                     sprintf("%.2f", median(check$ratio)), ", range ",
                                     sprintf("%.2f", min(check$ratio)), "-",
                                     sprintf("%.2f", max(check$ratio))), "."),
  "",
  kable(check),
  "",
  paste0("The same approximation on a 128,000-run Latin hypercube over the box of the reference's",
         " mean +- 3 sds, where the effective runs are many at every p (measured / predicted,",
         " over the trials; the intervals of these fits are not in the coverage tables):"),
  "",
  kable(local[, .(trials = .N, median_effective_runs = median(effective_runs),
                  median_predicted = median(predicted_effective_runs),
                  median_ratio = median(ratio), min_ratio = min(ratio), max_ratio = max(ratio)),
              by = p]),
  "",
  "## Growth with p",
  "",
  "Least squares on the medians per p: log(runs) = a + b log(p) (a power law, slope b),",
  "log(runs) = a + p log(f) (exponential, a factor f per parameter) and runs = a + c p (linear,",
  "c runs per parameter; left out for the plain rows).",
  "",
  kable(growth_tab),
  "",
  "The plain extrapolation's factor per added parameter between successive p (at p = 3 to 4",
  "griddy's test changes from 10 effective runs to 100, a factor 10 of the step; from p = 6 the",
  "last two parameters are weakly identified, so the step from 4 to 6 adds two weak ones):",
  "",
  kable(plain_steps, digits = 1),
  "")
writeLines(md, file.path("bench/results", paste0(out_name, ".md")))
cat(md, sep = "\n")

# ---- the vignette's summary: one row per p and trial -------------------------
first_plain <- function(n) plain[library_runs == n, .(p, trial, warned, coverage,
                                                       median_width_ratio, seconds)]
shipped <- Reduce(function(a, b) merge(a, b, by = c("p", "trial"), all.x = TRUE), list(
  plain_needed[, .(p, trial, plain_resolved_at = resolved_at, plain_largest_rung = largest_rung,
                   plain_effective_runs_largest = signif(effective_runs_largest, 4),
                   plain_predicted_largest = signif(predicted_largest, 4),
                   plain_extrapolated_resolve = signif(extrapolated_resolved, 4),
                   plain_extrapolated_target = signif(extrapolated_target, 4))],
  first_plain(2000L)[, .(p, trial, plain_2000_warned = warned,
                         plain_2000_coverage = round(coverage, 4),
                         plain_2000_width_ratio = signif(median_width_ratio, 4),
                         calibrate_seconds_2000 = signif(seconds, 3))],
  refined[, .(p, trial, refine_runs_added = runs_added, refine_reason = reason,
              refine_max_runs = max_runs, refine_seconds = signif(seconds, 3),
              refine_simulator_seconds = signif(simulator_seconds, 3),
              refine_effective_runs = signif(effective_runs, 4),
              refine_coverage = round(coverage, 4), ref_coverage = round(ref_coverage, 4),
              refine_width_ratio = signif(median_width_ratio, 4), refine_warned = warned,
              refine_missed_unwarned = missed_unwarned,
              refine_missed_unwarned_ref_covered = missed_unwarned_ref_covered)],
  local[, .(p, trial, local_effective_runs = signif(effective_runs, 4),
            local_predicted = signif(predicted_effective_runs, 4))],
  final[stage == "refine",
        .(parameters = .N, ref_width_median = signif(median(ref_upper - ref_lower), 4),
        # how far outside its interval a truth that the reference covers lay,
        # in interval widths (0 when there is no such miss)
        refine_farthest_other_miss = signif(max(0, ((pmax(lower - truth, truth - upper)) /
                                                      (upper - lower))[!covered & ref_covered]), 3),
        load = load[1]), by = .(p, trial)]))
if (out_name == "many-parameters-scaling") {
  fwrite(shipped, "inst/extdata/many_parameters_scaling.csv")
}
