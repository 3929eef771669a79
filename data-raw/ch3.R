# Chapter 3 of the thesis: the piston verification study, precomputed for
# vignettes/chapter3.Rmd.  Writes inst/extdata/ch3_*.csv.gz (all but ch3_refine,
# from data-raw/ch3-refine.R) and inst/extdata/ch3_session.txt.
# Run from the package root with griddy installed:  Rscript data-raw/ch3.R
# (3 minutes here on an otherwise idle 2-core machine, most of it building
# the 14 libraries; 20 minutes at load 6 before issue 15's precompute, when
# the correlated-error fits took up to 104 s each). ch3_session.txt records
# the last run's time and load.
library(griddy)
library(data.table)

t_start <- proc.time()[["elapsed"]]
sizes <- c(3, 4, 5, 6, 7, 8, 9, 10, 15, 22, 27, 32, 39, 47)   # values per coefficient
data_sizes <- c(6, 15, 27, 54)
ppc_sizes <- c(3, 39)           # the smallest library and the thesis's choice
ppc_points <- c(6, 54)
n_iter <- 35000
burn_in <- 15000
data_seed <- 2023               # shared with data-raw/ch4.R
rho_grid_values <- c(0, 0.2, 0.4, 0.6, 0.8)   # per x column, for the correlated-error fit
truth <- c(htc_undercrown = 1000, htc_gallery1 = 3000, htc_gallery2 = 2000)
out_dir <- "inst/extdata"

fields <- list()
for (disc in c(FALSE, TRUE)) for (n in data_sizes) {
  fields[[paste(disc, n)]] <- piston_field_data(n, discrepancy = disc, seed = data_seed)
}

# The 54-point library (27 locations x 2 conditions) per size; smaller data
# sets use the full-load columns of their locations.
subset_library <- function(lib54, field) {
  cols <- if (length(field$y) == 54) 1:54 else attr(field, "locations")
  x <- lib54$x[cols, , drop = FALSE]
  if (length(field$y) < 54) x$condition <- NULL
  sim_library(theta = lib54$theta, y = lib54$y[, cols, drop = FALSE], x = x)
}

# One row per coefficient: the summary (its estimate: the mean, or the median
# where the mean lies outside the interval), the library checks of summary()
# (resolution and edge mass per coefficient, effective runs, sampled vs
# exact, with its Monte Carlo reference), the chain's R-hat, the exact share
# of the most probable run and the mean number of runs a theta draw weighed
# (fit$head_length, over chains).
summarise_fit <- function(fit, keys, field, rho_x) {
  s <- summary(fit)
  a <- attr(s, "adequacy")
  th <- s[s$parameter %in% names(truth), ]
  res <- a$parameters[match(th$parameter, a$parameters$parameter), ]
  exact <- posterior_exact(fit$library, field, rho_x = rho_x)$run
  data.table(keys, parameter = th$parameter, estimate = th$estimate,
             estimate_type = th$estimate_type, mean = th$mean, median = th$median,
             lower = th$lower, upper = th$upper, truth = truth[th$parameter], rhat = th$rhat,
             effective_values = res$effective_values, limited = res$limited,
             mass_at_min = res$mass_at_min, mass_at_max = res$mass_at_max,
             effective_runs = a$effective_runs, top_share = max(exact),
             tv_distance = a$tv_distance, tv_reference = a$tv_reference,
             head_runs = mean(fit$head_length),
             precompute = fit$runtime[["precompute"]], sampling = fit$runtime[["sampling"]])
}

# calibrate() without its resolution and convergence warnings, recording
# whether each came.
quietly <- function(expr) {
  warned <- c(resolution_warning = FALSE, convergence_warning = FALSE)
  muffle <- function(which) function(w) {
    warned[[which]] <<- TRUE
    invokeRestart("muffleWarning")
  }
  value <- withCallingHandlers(expr,
                               griddy_warning_resolution = muffle("resolution_warning"),
                               griddy_warning_convergence = muffle("convergence_warning"))
  attr(value, "warned") <- warned
  value
}

estimates <- list()
ppc <- list()
build_time <- list()
for (k in sizes) {
  t0 <- proc.time()[["elapsed"]]
  lib54 <- piston_library(k, locations = 1:27, condition = c("full", "part"))
  build_time[[length(build_time) + 1]] <- data.table(n_per_dim = k, n_runs = k^3,
                                                     seconds = proc.time()[["elapsed"]] - t0)
  cat(sprintf("library %d^3 = %d runs built in %.1f s\n", k, k^3, build_time[[length(build_time)]]$seconds))
  for (disc in c(FALSE, TRUE)) for (n in data_sizes) {
    field <- fields[[paste(disc, n)]]
    lib <- subset_library(lib54, field)
    keys <- data.table(discrepancy = disc, n_points = n, n_per_dim = k, n_runs = k^3)
    seed <- 1000 * k + n + 500 * disc
    models <- list(
      list(label = "independent", update = "collapsed", rho_x = 0),
      list(label = "independent", update = "thesis", rho_x = 0)
    )
    if (disc) {
      models[[3]] <- list(label = "correlated", update = "collapsed",
                          rho_x = rep(list(rho_grid_values), ncol(lib$x)))
    }
    for (m in models) {
      fit <- quietly(calibrate(lib, field, rho_x = m$rho_x, n_iter = n_iter,
                               burn_in = burn_in, seed = seed, progress = FALSE,
                               update = m$update))
      row <- summarise_fit(fit, keys, field, m$rho_x)
      warned <- attr(fit, "warned")
      row[, `:=`(error_model = m$label, update = m$update,
                 resolution_warning = warned[["resolution_warning"]],
                 convergence_warning = warned[["convergence_warning"]])]
      estimates[[length(estimates) + 1]] <- row
      if (k %in% ppc_sizes && n %in% ppc_points && m$update == "collapsed") {
        p <- as.data.table(predict(fit, seed = seed))
        p[, `:=`(discrepancy = disc, n_points = n, n_per_dim = k, n_runs = k^3,
                 error_model = m$label, clean = attr(field, "clean"))]
        ppc[[length(ppc) + 1]] <- p
      }
    }
  }
  rm(lib54)
  gc()
}

estimates <- rbindlist(estimates)
ppc <- rbindlist(ppc, fill = TRUE)
f54 <- fields[["TRUE 54"]]
loc <- piston_locations()
measurements <- data.table(location = rep(loc$id, 2), surface = rep(loc$surface, 2),
                           index = rep(loc$index, 2), condition = rep(c("full", "part"), each = 27),
                           clean = attr(f54, "clean"), noise = attr(f54, "noise"),
                           discrepancy = attr(f54, "discrepancy"))

fwrite(estimates, file.path(out_dir, "ch3_estimates.csv.gz"))
fwrite(ppc, file.path(out_dir, "ch3_ppc.csv.gz"))
fwrite(measurements, file.path(out_dir, "ch3_measurements.csv.gz"))
fwrite(rbindlist(build_time), file.path(out_dir, "ch3_library_time.csv.gz"))

# The thesis's Appendix A loop in plain R against calibrate(), at the chapter's
# library sizes, for the vignette's runtime section: the chapter 3 rows of
# bench/results/thesis-configs.csv (bench/thesis-configs.R; bench/ is not
# installed), copied as they are. That benchmark's library is bench/helpers.R's
# synthetic three-coefficient response on the same grids with 54 data points
# and 35,000 iterations, not piston_model(): the plain loop weighs every run at
# every iteration, so its time depends on the number of runs, not on the model.
# plain_r_s is scaled from plain_iterations to iterations where they differ.
bench <- fread("bench/results/thesis-configs.csv")
bench <- bench[startsWith(config, "ch. 3"), .(runs, data_points, iterations, plain_iterations,
                                              plain_r_s, thesis_s, collapsed_s, machine, date)]
fwrite(bench, file.path(out_dir, "ch3_plain_loop.csv.gz"))

writeLines(c(paste("R", getRversion()), paste("griddy", packageVersion("griddy")),
             paste("date", format(Sys.time(), "%Y-%m-%d %H:%M")),
             paste("load", paste(readLines("/proc/loadavg", warn = FALSE), collapse = " ")),
             sprintf("seconds %.0f", proc.time()[["elapsed"]] - t_start)),
           file.path(out_dir, "ch3_session.txt"))
cat("done\n")
