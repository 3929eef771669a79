# Precomputes vignette("chapter4"): Griddy Gibbs against the thesis's
# traditional calibration (RobustCalibration without a discrepancy, as the
# thesis had none in its data model) and, beyond the thesis, Kennedy-O'Hagan
# with a GaSP or S-GaSP discrepancy, on the chapter-4 piston problem. Runs
# bench/koh-vs-griddy.R (all methods, 6/15/27/54 data points, timed in the same
# run; writes bench/results/koh-vs-griddy.csv) and ships the posterior
# summaries, posterior shapes, predictive checks, the runtime table and the
# thesis's printed tables in inst/extdata/chapter4.rds. About 13 minutes at a
# load average of 6 on 2 cores (the time is stored as settings$script_s).
#
# Usage, from the package root with griddy and RobustCalibration installed
# (or GRIDDY_LOAD_ALL=true to use pkgload::load_all()):
#   Rscript data-raw/ch4.R
script_start <- proc.time()[["elapsed"]]
source("bench/koh-vs-griddy.R")

truth <- c(htc_undercrown = 1000, htc_gallery1 = 3000, htc_gallery2 = 2000)

is_koh <- function(r) inherits(r$fit, "griddy_koh")

# Tables 4.1-4.4: 95% lower bound, estimate (posterior mean, as the thesis
# reports), truth, 95% upper; the median beside it, because the mean of a
# discrete (Griddy Gibbs) posterior can lie outside its own interval.
tables <- rbindlist(lapply(results, function(r) {
  s <- as.data.frame(unclass(r$summary))
  data.table(n_points = r$n_points, method = r$method, parameter = s$parameter,
             lower = s$lower, estimate = s$mean, median = s$median,
             truth = truth[s$parameter], upper = s$upper, ess_bulk = s$ess_bulk)
}))

# The thesis's tables 4.1-4.4 as printed (table 4.1 has one column of numbers;
# the vignette says which method it takes it to be). Its table 4.3 gives the
# traditional theta3 bounds as 1899.9 and 1855.7 (LB above UB), kept as printed.
thesis_tables <- data.table(
  n_points = rep(c(6, 15, 15, 27, 27, 54, 54), each = 3),
  method = rep(c("thesis: table 4.1 (one column)",
                 rep(c("thesis: traditional", "thesis: Griddy Gibbs"), 3)), each = 3),
  parameter = names(truth),
  lower = c(980.4, 2868.7, 1986.1, 959.2, 3129.5, 2108.6, 912.5, 2724.4, 2113.2,
            997.8, 2835.2, 1899.9, 912.5, 2724.4, 2113.2, 1007.0, 3013.1, 2092.6,
            912.5, 3023.5, 2113.2),
  estimate = c(1004.8, 2959.7, 2078.2, 971.8, 3188.9, 2159.8, 912.7, 2957.0, 2144.1,
               1005.4, 2864.5, 1926.8, 913.2, 3010.5, 2136.7, 1010.5, 3027.7, 2106.1,
               912.5, 3023.1, 2279.9),
  upper = c(1027.7, 3058.3, 2170.9, 985.0, 3253.5, 2212.2, 912.5, 3023.5, 2411.9,
            1013.1, 2894.8, 1855.7, 912.5, 3023.5, 2411.9, 1014.1, 3041.9, 2120.0,
            912.5, 3023.5, 2411.9))
thesis_tables[, truth := truth[parameter]]
# Table 3.1: the ranges of the thesis's library; table 4.5: its runtimes.
thesis_ranges <- data.table(parameter = names(truth), min = c(13.85, 8.61, 35.33),
                            max = c(11984.70, 11977.45, 12002.49))
thesis_runtime <- data.table(n_points = sizes,
                             traditional = c(653.8, 15321.5, 79817.2, 610182.3),
                             griddy = c(40.6, 42.8, 38.8, 38.8))

# Posterior shapes: Griddy Gibbs as mass per library value, KOH as draws
# thinned to 2,000 per fit (the vignette draws their densities).
griddy_mass <- rbindlist(lapply(results[grepl("^griddy ", names(results))], function(r) {
  th <- r$fit$library$theta[r$fit$draws$run, , drop = FALSE]
  rbindlist(lapply(names(th), function(p) {
    tab <- table(th[[p]])
    data.table(n_points = r$n_points, parameter = p, value = as.numeric(names(tab)),
               mass = as.numeric(tab) / nrow(th))
  }))
}))
koh_draws <- rbindlist(lapply(Filter(is_koh, results), function(r) {
  d <- r$fit$draws
  keep <- unique(round(seq(1, nrow(d), length.out = 2000)))
  melt(data.table(n_points = r$n_points, method = r$method, d[keep, r$fit$parameters]),
       id.vars = c("n_points", "method"), variable.name = "parameter",
       variable.factor = FALSE)
}))
library_values <- lapply(lib39_all$theta, unique)

# Posterior predictive checks: simulator output at the posterior draws (library
# outputs for Griddy Gibbs, emulator mean for KOH), mean and 95% band.
ppc <- rbindlist(lapply(results[!grepl("thesis", names(results))], function(r) {
  p <- if (inherits(r$fit, "griddy_fit")) predict(r$fit, seed = 1) else predict(r$fit)
  f <- field[[as.character(r$n_points)]]
  data.table(n_points = r$n_points, method = r$method, point = seq_len(nrow(p)),
             r = p$r, z = p$z, observed = p$observed, clean = attr(f, "clean"),
             mean = p$mean, lower = p$lower, upper = p$upper)
}))

koh_settings <- rbindlist(lapply(Filter(is_koh, results), function(r) {
  data.table(n_points = r$n_points, method = r$method,
             acceptance_theta = r$fit$acceptance[["theta"]],
             acceptance_kernel = r$fit$acceptance[["kernel"]],
             emulator_s = r$fit$runtime[["emulator"]], tuning_s = r$fit$runtime[["tuning"]],
             sampling_s = r$fit$runtime[["sampling"]],
             proposal_sd = paste(signif(r$fit$proposal_sd, 3), collapse = " / "),
             # the noise variance (RobustCalibration's sigma_0^2, with or without
             # a discrepancy)
             sigma2_median = stats::median(r$fit$draws$sigma2),
             sigma2_lower = stats::quantile(r$fit$draws$sigma2, 0.025, names = FALSE),
             sigma2_upper = stats::quantile(r$fit$draws$sigma2, 0.975, names = FALSE))
}))
griddy_settings <- rbindlist(lapply(results[grepl("^griddy", names(results))], function(r) {
  data.table(n_points = r$n_points, method = r$method,
             precompute_s = r$fit$runtime[["precompute"]],
             sampling_s = r$fit$runtime[["sampling"]],
             runs_visited = length(unique(r$fit$draws$run)),
             modal_run_share = max(tabulate(r$fit$draws$run)) / nrow(r$fit$draws))
}))

script_s <- proc.time()[["elapsed"]] - script_start
chapter4 <- list(
  tables = tables, griddy_mass = griddy_mass, koh_draws = koh_draws,
  library_values = library_values, ppc = ppc, runtime = bench,
  koh_settings = koh_settings, griddy_settings = griddy_settings,
  thesis_tables = thesis_tables, thesis_ranges = thesis_ranges,
  thesis_runtime = thesis_runtime,
  settings = list(data_seed = data_seed, griddy_iter = griddy_iter,
                  griddy_burn = griddy_burn, koh_iter = koh_iter, koh_burn = koh_burn,
                  koh_tune_rounds = koh_tune_rounds,
                  koh_tune_iter = formals(koh_calibrate)$tune_iter,
                  noise_var = formals(piston_field_data)$noise_var,
                  discrepancy_var = formals(piston_field_data)$discrepancy_var,
                  library_build_s = build_time, script_s = script_s,
                  versions = c(griddy = format(utils::packageVersion("griddy")),
                               RobustCalibration = format(utils::packageVersion("RobustCalibration")),
                               RobustGaSP = format(utils::packageVersion("RobustGaSP")),
                               R = R.version.string),
                  date = format(Sys.time(), "%Y-%m-%d %H:%M"))
)
saveRDS(chapter4, "inst/extdata/chapter4.rds", compress = "xz")
cat("inst/extdata/chapter4.rds:", file.size("inst/extdata/chapter4.rds"), "bytes\n")
