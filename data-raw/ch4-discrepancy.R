# Precomputes the "With a discrepancy in the model" section of
# vignette("chapter4") (issue 23, item 5): on the chapter-4 data
# (piston_field_data(n, discrepancy = TRUE, seed = 2023), n = 6, 15, 27, 54),
#  * griddy without a discrepancy: calibrate() over the 59,319-run library
#    (39 values per coefficient), rho_x = 0, as in data-raw/ch4.R;
#  * griddy with gp_discrepancy() (the default grid) on the same library;
#  * RobustCalibration's rcalibration() with discrepancy_type "GaSP" and
#    "S-GaSP", through koh_calibrate() (a ppgasp emulator of the 343-run
#    library, 7 values per coefficient; 6 tuning runs of 1,000 iterations as
#    in data-raw/ch4.R, then 12,000 iterations, burn-in 2,000).
# griddy runs 35,000 iterations (burn-in 15,000). Per fit and coefficient:
# posterior mean and median, 95% interval, whether it holds the truth; per
# fit: elapsed and CPU seconds of the call (griddy: calibrate(); KOH: the
# emulator, tuning and sampling), the smallest bulk ESS over the coefficients
# that move, and for griddy with a discrepancy its log Bayes factor.
# Fixed seeds (data 2023, each fit seed n). Writes
# inst/extdata/chapter4_discrepancy.rds (xz).
#
# Usage, from the package root with griddy and RobustCalibration installed
# (or GRIDDY_LOAD_ALL=true to use pkgload::load_all()):
#   GRIDDY_LOAD_ALL=true Rscript data-raw/ch4-discrepancy.R
# About 5-10 minutes on a shared 2-core machine (stored as settings$script_s).
script_start <- proc.time()[["elapsed"]]
source("bench/helpers.R")
load_griddy()
stopifnot(requireNamespace("RobustCalibration", quietly = TRUE))
start_note <- machine_note()

sizes <- c(6, 15, 27, 54)
data_seed <- 2023
griddy_iter <- 35000L
griddy_burn <- 15000L
koh_iter <- 12000L
koh_burn <- 2000L
koh_tune_rounds <- 6L
truth <- c(htc_undercrown = 1000, htc_gallery1 = 3000, htc_gallery2 = 2000)
discrepancy <- gp_discrepancy()

# Libraries once over all 54 outputs, cut to each data set's outputs (as in
# bench/koh-vs-griddy.R).
cut_library <- function(lib54, f) {
  key54 <- paste(lib54$x$condition, lib54$x$r, lib54$x$z)
  cond_id <- match(attr(f, "condition"), piston_conditions()$condition)
  x <- f$x
  key <- paste(if (length(cond_id) > 1L) x$condition else cond_id, x$r, x$z)
  cols <- match(key, key54)
  stopifnot(!anyNA(cols))
  sim_library(lib54$theta, lib54$y[, cols, drop = FALSE], x = x)
}
# CH4_INPUTS: an rds of list(lib39 = piston_case_inputs(39), lib7 =
# piston_case_inputs(7)) (bench/helpers.R; the same two libraries) made
# earlier, as building them takes 0.5-6 minutes
cache <- Sys.getenv("CH4_INPUTS", "")
if (nzchar(cache) && file.exists(cache)) {
  cached <- readRDS(cache)
  lib39_all <- case_library(cached$lib39)
  lib7_all <- case_library(cached$lib7)
} else {
  lib39_all <- piston_library(39, locations = 1:27, condition = c("full", "part"))
  lib7_all <- piston_library(7, locations = 1:27, condition = c("full", "part"))
}

# One fit's rows: per coefficient its summary, and the call's cost.
fit_rows <- function(n, method, m, hyper_points = NA_integer_) {
  s <- as.data.frame(unclass(summary(m$value)))
  s <- s[s$parameter %in% names(truth), ]
  ev <- if (!is.na(hyper_points)) discrepancy_evidence(m$value)
  data.table(n_points = n, method = method, parameter = s$parameter, estimate = s$mean,
             median = s$median, lower = s$lower, upper = s$upper, truth = truth[s$parameter],
             covers = s$lower <= truth[s$parameter] & truth[s$parameter] <= s$upper,
             ess_bulk = s$ess_bulk, elapsed_s = m$elapsed_s, cpu_s = m$cpu_s,
             other_cores = m$other_cores, hyper_points = hyper_points,
             log_bayes_factor = if (is.null(ev)) NA_real_ else ev$log_bayes_factor,
             prob_none = if (is.null(ev)) NA_real_ else ev$prob_none)
}

rows <- list()
for (n in sizes) {
  f <- piston_field_data(n, discrepancy = TRUE, seed = data_seed)
  lib39 <- cut_library(lib39_all, f)
  lib7 <- cut_library(lib7_all, f)
  m <- measure_call(calibrate(lib39, f, n_iter = griddy_iter, burn_in = griddy_burn,
                              seed = n, progress = FALSE))
  rows[[length(rows) + 1]] <- fit_rows(n, "griddy, no discrepancy", m)
  hyper <- nrow(griddy:::discrepancy_points(discrepancy, lib39))
  # the gap warning is the point of the fit; its Bayes factor is stored
  m <- measure_call(suppressWarnings(calibrate(lib39, f, n_iter = griddy_iter,
                                               burn_in = griddy_burn, seed = n,
                                               discrepancy = discrepancy, progress = FALSE)))
  rows[[length(rows) + 1]] <- fit_rows(n, "griddy, gp_discrepancy()", m, hyper)
  for (d in c("GaSP", "S-GaSP")) {
    m <- measure_call(suppressWarnings(koh_calibrate(
      lib7, f, discrepancy = d, n_iter = koh_iter, burn_in = koh_burn,
      tune_rounds = koh_tune_rounds, seed = n)))
    rows[[length(rows) + 1]] <- fit_rows(n, paste0("RobustCalibration, ", d), m)
  }
  cat(sprintf("n = %2d done (%.0f s so far)\n", n, proc.time()[["elapsed"]] - script_start))
}
results <- rbindlist(rows)
print(results[, .(n_points, method, parameter, estimate = round(estimate, 1),
                  lower = round(lower, 1), upper = round(upper, 1), covers,
                  elapsed_s = round(elapsed_s, 2), cpu_s = round(cpu_s, 2),
                  log_bf = round(log_bayes_factor, 1))])

chapter4_discrepancy <- list(
  results = results,
  settings = list(data_seed = data_seed, griddy_iter = griddy_iter, griddy_burn = griddy_burn,
                  koh_iter = koh_iter, koh_burn = koh_burn, koh_tune_rounds = koh_tune_rounds,
                  discrepancy = unclass(discrepancy)[c("ratio", "length_x", "length_t",
                                                       "prior_none", "orthogonal")],
                  n_runs = nrow(lib39_all$theta), n_runs_emulator = nrow(lib7_all$theta),
                  threads = griddy_threads(),
                  machine = paste0(start_note, "; at end: load average ",
                                   sub(".*load average ", "", machine_note())),
                  script_s = proc.time()[["elapsed"]] - script_start,
                  versions = c(griddy = format(utils::packageVersion("griddy")),
                               RobustCalibration = format(utils::packageVersion("RobustCalibration")),
                               R = R.version.string),
                  date = format(Sys.time(), "%Y-%m-%d %H:%M"))
)
saveRDS(chapter4_discrepancy, "inst/extdata/chapter4_discrepancy.rds", compress = "xz")
cat("inst/extdata/chapter4_discrepancy.rds:",
    file.size("inst/extdata/chapter4_discrepancy.rds"), "bytes\n")
