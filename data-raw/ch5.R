# Chapter 5 of Stewart (2023): tyre calibration on the stand-in rig.
#
# Builds the 2,000 x 3 = 6,000-run Fiala library, the held-out "measured"
# data (Fiala and PAC2002-style at k = 450 N/mm, c = 1.5 N s/mm plus noise),
# runs the thesis's independent-error calibrations (and Fiala-to-PAC2002
# again with a rigid-disc Fiala library) and the same with an AR(1)
# correlation over time (rho_t sampled, Appendix B), and stores small
# summaries in inst/extdata/ch5.rds for vignettes/chapter5.Rmd.
#
# Run from the package root, single-threaded, after installing griddy:
#   R_LIBS=<private lib> Rscript data-raw/ch5.R
# Takes about 2 minutes on one core (most of it the two libraries).

library(griddy)
data.table::setDTthreads(1)
t_script <- proc.time()[["elapsed"]]

seeds <- c(library = 2023, noise_fiala = 501, noise_pac = 502, fit = 1, ppc = 1)
truth <- c(k = 450, c = 1.5)
noise_sd <- 60                 # N: 2% of the 3 kN static load (thesis gives none)
n_iter <- 50000                # thesis: 50,000 iterations
burn_in <- 10000
chains <- 2
# AR(1) over time: t is scaled to [0, 1] over the 500 samples, so the lag-one
# correlation is phi = rho_t^(1/499) and rho_t = phi^499. phi below ~0.25
# underflows rho_t to 0 in double precision, so the grid's smallest non-zero
# phi is 0.3.
phi <- c(0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 0.98, 0.99, 0.995, 0.998, 0.999)
rho_t_grid <- c(0, phi^499)

# ---- Sensitivity study (figs 5.2-5.3) ---------------------------------------
# The thesis ran it on one cleat "of height 100 mm"; with the factor-10
# rescaling of the cleat heights (see ?tyre_cleat_heights) that is 10 mm.
sens_height <- 10
steps <- 0:10 / 10
rng <- tyre_param_ranges()
sens_k <- rng$min[1] + steps * (rng$max[1] - rng$min[1])
sens_c <- rng$min[2] + steps * (rng$max[2] - rng$min[2])
fz_k <- tyre_cleat_model(sens_k, truth[["c"]], height = sens_height)
fz_c <- tyre_cleat_model(truth[["k"]], sens_c, height = sens_height)
time <- attr(fz_k, "time")
sensitivity <- data.table::rbindlist(list(
  data.table::data.table(varied = "k", step = rep(steps, each = length(time)),
                         k = rep(sens_k, each = length(time)), c = truth[["c"]],
                         time = time, fz = round(as.vector(t(fz_k)), 1)),
  data.table::data.table(varied = "c", step = rep(steps, each = length(time)),
                         k = truth[["k"]], c = rep(sens_c, each = length(time)),
                         time = time, fz = round(as.vector(t(fz_c)), 1))))

# ---- Library (2,000 LHS combinations x 3 heights) ---------------------------
t0 <- proc.time()[["elapsed"]]
set.seed(seeds[["library"]])
lib <- tyre_library(2000)
t_library <- proc.time()[["elapsed"]] - t0
# the truth is held out: a Latin hypercube never hits it exactly
stopifnot(!any(lib$theta$k == truth[["k"]] & lib$theta$c == truth[["c"]]))
# The same design with rigid-disc contact for the Fiala runs (the contact of
# the PAC2002-style data), to separate the contact from the force law.
t0 <- proc.time()[["elapsed"]]
set.seed(seeds[["library"]])
lib_disc <- tyre_library(2000, contact = "disc")
t_library_disc <- proc.time()[["elapsed"]] - t0
stopifnot(identical(lib_disc$theta, lib$theta))
step_k <- diff(range(lib$theta$k)) / sqrt(nrow(lib$theta))
step_c <- diff(range(lib$theta$c)) / sqrt(nrow(lib$theta))

# ---- Field data -------------------------------------------------------------
field <- list(
  fiala = tyre_field_data(truth[["k"]], truth[["c"]], model = "fiala",
                          noise_sd = noise_sd, seed = seeds[["noise_fiala"]]),
  pac2002 = tyre_field_data(truth[["k"]], truth[["c"]], model = "pac2002",
                            noise_sd = noise_sd, seed = seeds[["noise_pac"]]))

# ---- Calibrations ------------------------------------------------------------
keep_warnings <- function(expr) {
  msgs <- character()
  value <- withCallingHandlers(expr, warning = function(w) {
    msgs <<- c(msgs, conditionMessage(w))
    invokeRestart("muffleWarning")
  })
  list(value = value, warnings = msgs)
}

# Everything the vignette needs from one fit, small.
fit_record <- function(fit, warnings, rho_t) {
  s <- summary(fit)
  ad <- attr(s, "adequacy")
  printed <- utils::capture.output(print(s))
  exact <- posterior_exact(fit$library, list_field(fit), rho_t = rho_t)
  sampled <- tabulate(fit$draws$run, nbins = nrow(fit$library$y)) / nrow(fit$draws)
  runs <- which(sampled > 0 | exact$run > 1e-12)
  run_prob <- data.table::data.table(run = runs, k = fit$library$theta$k[runs],
                                     c = fit$library$theta$c[runs],
                                     sampled = sampled[runs], exact = exact$run[runs])
  d <- fit$draws
  thin_trace <- d[d$iteration %% 100 == 0, ]
  trace <- data.table::data.table(chain = thin_trace$chain, iteration = thin_trace$iteration,
                                  k = fit$library$theta$k[thin_trace$run],
                                  c = fit$library$theta$c[thin_trace$run],
                                  tau = thin_trace$tau,
                                  rho_t = fit$grid$rho_t[thin_trace$grid_point])
  rho_post <- NULL
  if (!is.null(fit$grid$rho_t)) {
    rho_post <- data.table::data.table(
      rho_t = fit$grid$rho_t, phi = fit$grid$rho_t^(1 / 499),
      sampled = tabulate(fit$draws$grid_point, nbins = nrow(fit$grid)) / nrow(fit$draws),
      exact = exact$rho$prob)
  }
  ppc <- data.table::as.data.table(predict(fit, ndraws = 1000, seed = seeds[["ppc"]]))
  ppc[, c("observed", "mean", "lower", "upper", "pred_lower", "pred_upper") :=
        lapply(.SD, round, 1),
      .SDcols = c("observed", "mean", "lower", "upper", "pred_lower", "pred_upper")]
  sigma <- 1 / sqrt(fit$draws$tau)
  list(summary = as.data.frame(unclass(s))[, c("parameter", "mean", "median", "lower",
                                               "upper", "ess", "rhat")],
       printed = printed, warnings = warnings,
       adequacy = list(effective_runs = ad$effective_runs_sampled,
                       effective_runs_exact = ad$effective_runs,
                       top_share = max(sampled), top_share_exact = max(exact$run),
                       parameters = ad$parameters, tv_distance = ad$tv_distance),
       sigma = stats::quantile(sigma, c(0.025, 0.5, 0.975), names = TRUE),
       run_prob = run_prob, trace = trace, rho_post = rho_post, ppc = ppc,
       log_evidence = exact$log_evidence, runtime = fit$runtime)
}

list_field <- function(fit) {
  field_data(fit$y_field, x = fit$library$x, t = fit$library$t)
}

fits <- list()
cases <- list(fiala = list(lib = lib, data = "fiala"),
              pac2002 = list(lib = lib, data = "pac2002"),
              pac2002_disc = list(lib = lib_disc, data = "pac2002"))
for (case in names(cases)) {
  data_model <- cases[[case]]$data
  for (error in c("independent", "ar1")) {
    rho_t <- if (error == "independent") 0 else rho_t_grid
    res <- keep_warnings(calibrate(cases[[case]]$lib, field[[data_model]], rho_t = rho_t,
                                   n_iter = n_iter, burn_in = burn_in, chains = chains,
                                   seed = seeds[["fit"]]))
    key <- paste(case, error, sep = "_")
    fits[[key]] <- fit_record(res$value, res$warnings, rho_t)
    fits[[key]]$ppc[, clean := round(as.vector(t(attr(field[[data_model]], "clean"))), 1)]
    cat(key, ": precompute", format(res$value$runtime[["precompute"]], digits = 3),
        "s, sampling", format(res$value$runtime[["sampling"]], digits = 3), "s\n")
    rm(res)
  }
}

t_total <- proc.time()[["elapsed"]] - t_script
ch5 <- list(
  settings = list(seeds = seeds, truth = truth, noise_sd = noise_sd, n_iter = n_iter,
                  burn_in = burn_in, chains = chains, phi = phi, rho_t_grid = rho_t_grid,
                  sens_height = sens_height, heights = lib$x$height,
                  step_k = step_k, step_c = step_c),
  sensitivity = sensitivity,
  design = data.table::data.table(k = round(lib$theta$k, 3), c = round(lib$theta$c, 5)),
  fits = fits,
  timings = c(library = t_library, library_disc = t_library_disc, total = t_total),
  session = list(r = R.version.string, griddy = as.character(utils::packageVersion("griddy")),
                 date = format(Sys.Date())))
out <- file.path("inst", "extdata", "ch5.rds")
saveRDS(ch5, out, compress = "xz")
cat("library build", format(t_library, digits = 3), "s; whole script",
    format(t_total, digits = 3), "s; wrote", out, format(file.size(out) / 1024, digits = 3),
    "KiB\n")
