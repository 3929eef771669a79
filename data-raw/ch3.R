# Chapter 3 of the thesis: the piston verification study, precomputed for
# vignettes/chapter3.Rmd.  Writes inst/extdata/ch3_*.csv.gz.
# Run from the package root with griddy installed:  Rscript data-raw/ch3.R
# (6 minutes here on a quiet machine, 16 under load; most of it building the
# 14 libraries and the correlated-error fits at the largest sizes).
library(griddy)
library(data.table)

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

# One row per coefficient: the summary, the library checks of summary()
# (resolution and edge mass per coefficient, effective runs, sampled vs
# exact) and the exact share of the most probable run.
summarise_fit <- function(fit, keys, field, rho_x) {
  s <- summary(fit)
  a <- attr(s, "adequacy")
  th <- s[s$parameter %in% names(truth), ]
  res <- a$parameters[match(th$parameter, a$parameters$parameter), ]
  exact <- posterior_exact(fit$library, field, rho_x = rho_x)$run
  data.table(keys, parameter = th$parameter, mean = th$mean, median = th$median,
             lower = th$lower, upper = th$upper, truth = truth[th$parameter],
             effective_values = res$effective_values, limited = res$limited,
             mass_at_min = res$mass_at_min, mass_at_max = res$mass_at_max,
             effective_runs = a$effective_runs, top_share = max(exact),
             tv_distance = a$tv_distance,
             precompute = fit$runtime[["precompute"]], sampling = fit$runtime[["sampling"]])
}

# calibrate() without its resolution warning, recording whether it warned.
quietly <- function(expr) {
  warned <- FALSE
  value <- withCallingHandlers(expr, griddy_warning_resolution = function(w) {
    warned <<- TRUE
    invokeRestart("muffleWarning")
  })
  attr(value, "resolution_warning") <- warned
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
      row[, `:=`(error_model = m$label, update = m$update,
                 resolution_warning = attr(fit, "resolution_warning"))]
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
writeLines(c(paste("R", getRversion()), paste("griddy", packageVersion("griddy")),
             paste("date", format(Sys.time(), "%Y-%m-%d %H:%M")),
             paste("load", paste(readLines("/proc/loadavg", warn = FALSE), collapse = " "))),
           file.path(out_dir, "ch3_session.txt"))
cat("done\n")
