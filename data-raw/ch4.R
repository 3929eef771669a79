# Precomputes vignette("chapter4"): Griddy Gibbs against a traditional
# Kennedy-O'Hagan calibration (RobustCalibration) on the thesis's chapter-4
# piston problem. Runs bench/koh-vs-griddy.R (both methods, 6/15/27/54 data
# points, timed in the same run; writes bench/results/koh-vs-griddy.csv) and
# ships the posterior summaries, posterior shapes, predictive checks and the
# runtime table in inst/extdata/chapter4.rds.
#
# Usage, from the package root with griddy and RobustCalibration installed
# (or GRIDDY_LOAD_ALL=true to use pkgload::load_all()):
#   Rscript data-raw/ch4.R
source("bench/koh-vs-griddy.R")

truth <- c(htc_undercrown = 1000, htc_gallery1 = 3000, htc_gallery2 = 2000)

# Tables 4.1-4.4: 95% lower bound, estimate (posterior mean), truth, 95% upper.
tables <- rbindlist(lapply(results, function(r) {
  s <- as.data.frame(unclass(r$summary))[, c("parameter", "mean", "lower", "upper", "ess_bulk")]
  data.table(n_points = r$n_points, method = r$method, parameter = s$parameter,
             lower = s$lower, estimate = s$mean, truth = truth[s$parameter],
             upper = s$upper, ess_bulk = s$ess_bulk)
}))

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
koh_draws <- rbindlist(lapply(results[grepl("GaSP", names(results))], function(r) {
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

koh_settings <- rbindlist(lapply(results[grepl("GaSP", names(results))], function(r) {
  data.table(n_points = r$n_points, method = r$method,
             acceptance_theta = r$fit$acceptance[["theta"]],
             acceptance_kernel = r$fit$acceptance[["kernel"]],
             emulator_s = r$fit$runtime[["emulator"]], tuning_s = r$fit$runtime[["tuning"]],
             sampling_s = r$fit$runtime[["sampling"]],
             proposal_sd = paste(signif(r$fit$proposal_sd, 3), collapse = " / "))
}))
griddy_settings <- rbindlist(lapply(results[grepl("^griddy", names(results))], function(r) {
  data.table(n_points = r$n_points, method = r$method,
             precompute_s = r$fit$runtime[["precompute"]],
             sampling_s = r$fit$runtime[["sampling"]],
             runs_visited = length(unique(r$fit$draws$run)))
}))

chapter4 <- list(
  tables = tables, griddy_mass = griddy_mass, koh_draws = koh_draws,
  library_values = library_values, ppc = ppc, runtime = bench,
  koh_settings = koh_settings, griddy_settings = griddy_settings,
  settings = list(data_seed = data_seed, griddy_iter = griddy_iter,
                  griddy_burn = griddy_burn, koh_iter = koh_iter, koh_burn = koh_burn,
                  library_build_s = build_time,
                  versions = c(griddy = format(utils::packageVersion("griddy")),
                               RobustCalibration = format(utils::packageVersion("RobustCalibration")),
                               RobustGaSP = format(utils::packageVersion("RobustGaSP")),
                               R = R.version.string),
                  date = format(Sys.time(), "%Y-%m-%d %H:%M"))
)
saveRDS(chapter4, "inst/extdata/chapter4.rds", compress = "xz")
cat("inst/extdata/chapter4.rds:", file.size("inst/extdata/chapter4.rds"), "bytes\n")
