# Chapter 5 of Stewart (2023): tyre calibration on the stand-in rig.
#
# Builds the 2,000 x 3 = 6,000-run Fiala library (rectangular contact patch
# of uniform pressure, the thesis's Fiala assumption), the held-out
# "measured" data (Fiala and PAC2002-style, rigid-disc contact as in the
# thesis, at k = 450 N/mm, c = 1.5 N s/mm plus noise), runs the thesis's
# independent-error calibrations (and Fiala-to-PAC2002 again with a
# rigid-disc Fiala library, to isolate the force law) and the same with an
# AR(1) correlation over time (rho_t sampled, Appendix B), and stores small
# summaries in inst/extdata/ch5.rds for vignettes/chapter5.Rmd. Then
# (issue 12) refines every fit whose intervals the library's resolution
# limits, with refine(): once with the tyre stand-in as the simulator, once
# without a simulator (new runs predicted by refine()'s emulator), and
# stores what each achieved.
#
# Run from the package root, single-threaded, after installing griddy:
#   R_LIBS=<private lib> Rscript data-raw/ch5.R
# Took 9.4 minutes (564 s) on a shared 2-core machine at load average about
# 2 (23 minutes at load 6): most of it the twelve refine() calls; the two
# libraries take about half a minute (the rigid-disc one is 4.6 times as
# costly per run).

library(griddy)
data.table::setDTthreads(1)
t_script <- proc.time()[["elapsed"]]

seeds <- c(library = 2023, noise_fiala = 501, noise_pac = 502, fit = 1, ppc = 1,
           refine = 12)
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
fz_k <- tyre_cleat_model(sens_k, truth[["c"]], height = sens_height)   # patch contact
fz_c <- tyre_cleat_model(truth[["k"]], sens_c, height = sens_height)
time <- attr(fz_k, "time")
sensitivity <- data.table::rbindlist(list(
  data.table::data.table(varied = "k", step = rep(steps, each = length(time)),
                         k = rep(sens_k, each = length(time)), c = truth[["c"]],
                         time = time, fz = round(as.vector(t(fz_k)), 1)),
  data.table::data.table(varied = "c", step = rep(steps, each = length(time)),
                         k = truth[["k"]], c = rep(sens_c, each = length(time)),
                         time = time, fz = round(as.vector(t(fz_c)), 1))))

# ---- The contact models at the truth ---------------------------------------
# Fz of the Fiala tyre at (450, 1.5) on the three cleats with each contact
# (point follower: the default before the contact patch), and of the
# PAC2002-style tyre with its rigid disc, noise-free.
contact_runs <- data.table::rbindlist(lapply(c("patch", "point", "disc", "pac2002"), function(ct) {
  fz <- if (ct == "pac2002") {
    tyre_cleat_model(truth[["k"]], truth[["c"]], model = "pac2002")
  } else {
    tyre_cleat_model(truth[["k"]], truth[["c"]], contact = ct)
  }
  data.table::data.table(contact = ct, height = rep(attr(fz, "height"), each = length(time)),
                         time = time, fz = round(as.vector(fz), 1))
}))
# the patch length (mm) at the truth and at the ends of the k range
patch_length <- stats::setNames(tyre_patch_length(c(truth[["k"]], rng$min[1], rng$max[1])),
                                c("truth", "k_min", "k_max"))

# ---- Library (2,000 LHS combinations x 3 heights) ---------------------------
t0 <- proc.time()[["elapsed"]]
set.seed(seeds[["library"]])
lib <- tyre_library(2000)             # Fiala, rectangular-patch contact
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
      exact = exact$grid$prob)
  }
  ppc <- data.table::as.data.table(predict(fit, ndraws = 1000, seed = seeds[["ppc"]]))
  ppc[, c("observed", "mean", "lower", "upper", "pred_lower", "pred_upper") :=
        lapply(.SD, round, 1),
      .SDcols = c("observed", "mean", "lower", "upper", "pred_lower", "pred_upper")]
  sigma <- 1 / sqrt(fit$draws$tau)
  list(summary = as.data.frame(unclass(s))[, c("parameter", "mean", "median", "lower",
                                               "upper", "ess_bulk", "ess_tail", "rhat", "mcse",
                                               "resolution")],
       # the summary itself, printed by the installed griddy when the vignette knits
       summary_object = s, warnings = warnings,
       adequacy = list(effective_runs = ad$effective_runs,
                       effective_runs_sampled = ad$effective_runs_sampled,
                       top_share = max(exact$run), top_share_sampled = max(sampled),
                       parameters = ad$parameters, tv_distance = ad$tv_distance),
       sigma = stats::quantile(sigma, c(0.025, 0.5, 0.975), names = TRUE),
       run_prob = run_prob, trace = trace, rho_post = rho_post, ppc = ppc,
       log_evidence = exact$log_evidence, runtime = fit$runtime)
}

list_field <- function(fit) {
  field_data(fit$y_field, x = fit$library$x, t = fit$library$t)
}

fits <- list()
plain <- list()   # the fit objects, for refine() below (not stored)
cases <- list(fiala = list(lib = lib, data = "fiala", contact = "patch"),
              pac2002 = list(lib = lib, data = "pac2002", contact = "patch"),
              pac2002_disc = list(lib = lib_disc, data = "pac2002", contact = "disc"))
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
    plain[[key]] <- res$value
    rm(res)
  }
}

# ---- Refinement (issue 12) --------------------------------------------------
# refine() adds runs where the posterior has its mass until every interval is
# resolved (>= 10 effective distinct values, bounds stable between rounds) or
# max_runs runs are added. The simulator maps theta rows (k, c) to the
# library's outputs: the 3 cleat heights x 500 samples, in blocks by height,
# with the contact of the library refined.
tyre_simulator <- function(theta, contact) {
  y <- tyre_cleat_model(as.matrix(theta[, c("k", "c")]), height = lib$x$height,
                        contact = contact)
  attributes(y) <- list(dim = dim(y))
  y
}
# it reproduces the libraries' rows exactly
check_rows <- c(1, 2, 1000, 1999, 2000)
stopifnot(identical(tyre_simulator(lib$theta[check_rows, ], "patch"), lib$y[check_rows, ]),
          identical(tyre_simulator(lib_disc$theta[check_rows, ], "disc"),
                    lib_disc$y[check_rows, ]))
# Cost of one (k, c) run (3 heights x 500 samples of RK4), from the libraries.
sim_cost <- c(patch = t_library, disc = t_library_disc) / nrow(lib$theta)
# At most as many new runs as the library has: at most 2,000 x sim_cost of
# simulation per call (about 35 s with patch contact, 130 s with disc), and
# 10 rounds of refine()'s default 200 runs.
max_runs <- 2000

# A refined fit, small: summary, resolution table, what refine() did.
refined_record <- function(fit, warnings, elapsed) {
  s <- summary(fit)
  ad <- attr(s, "adequacy")
  exact <- griddy:::exact_from_problem(fit)
  n0 <- nrow(fit$library$base$theta)
  n_runs <- nrow(fit$library$theta)
  sampled <- tabulate(fit$draws$run, nbins = n_runs) / nrow(fit$draws)
  runs <- which(exact$run > 1e-6 | sampled > 0)
  run_prob <- data.table::data.table(
    run = runs, added = runs > n0, k = fit$library$theta$k[runs],
    c = fit$library$theta$c[runs], sampled = sampled[runs], exact = exact$run[runs])
  ref <- fit$refinement
  history <- data.table::rbindlist(lapply(seq_along(ref$history), function(r) {
    data.table::data.table(round = r - 1L, ref$history[[r]])
  }))
  sigma <- 1 / sqrt(fit$draws$tau)
  list(summary = as.data.frame(unclass(s))[, c("parameter", "mean", "median", "lower",
                                               "upper", "ess_bulk", "ess_tail", "rhat", "mcse",
                                               "resolution")],
       summary_object = s, warnings = unique(warnings),
       resolution = ad$parameters,
       adequacy = list(effective_runs = ad$effective_runs,
                       effective_runs_sampled = ad$effective_runs_sampled,
                       tv_distance = ad$tv_distance),
       runs = n_runs, runs_added = ref$runs_added, rounds = ref$rounds,
       reason = ref$reason, source = ref$source, history = history,
       sigma = stats::quantile(sigma, c(0.025, 0.5, 0.975), names = TRUE),
       rho_post = if (!is.null(fit$grid$rho_t)) {
         data.table::data.table(rho_t = fit$grid$rho_t, phi = fit$grid$rho_t^(1 / 499),
                                exact = exact$grid$prob)
       },
       run_prob = run_prob, elapsed = elapsed, runtime = fit$runtime)
}

# The emulator's error where it matters: the predicted runs holding 99.9% of
# the refined posterior, simulated after all. rms over outputs (N) of
# predicted - simulated, and each run's misfit to the data (rms, N) with the
# predicted and the simulated outputs.
emulator_check <- function(fit, contact) {
  exact <- griddy:::exact_from_problem(fit)$run
  n0 <- nrow(fit$library$base$theta)
  ord <- order(exact, decreasing = TRUE)
  top <- ord[seq_len(which(cumsum(exact[ord]) >= 0.999)[1])]
  top <- top[top > n0]
  if (length(top) == 0L) return(NULL)
  predicted <- fit$library$added$y[top - n0, , drop = FALSE]
  simulated <- tyre_simulator(fit$library$theta[top, ], contact)
  y_field <- as.vector(t(fit$y_field))
  rms_misfit <- function(y) sqrt(rowMeans((y - matrix(y_field, nrow(y), ncol(y), byrow = TRUE))^2))
  data.table::data.table(run = top, k = fit$library$theta$k[top], c = fit$library$theta$c[top],
                         exact = exact[top], rel_var = fit$library$added$rel_var[top - n0],
                         rms_error = sqrt(rowMeans((predicted - simulated)^2)),
                         misfit_predicted = rms_misfit(predicted),
                         misfit_simulated = rms_misfit(simulated))
}

refined <- list()
for (key in names(plain)) {
  limited <- fits[[key]]$summary$resolution[fits[[key]]$summary$parameter %in% c("k", "c")]
  if (!any(limited == "limited")) next
  case <- sub("_(independent|ar1)$", "", key)
  contact <- cases[[case]]$contact
  for (source in c("simulator", "emulator")) {
    t0 <- proc.time()[["elapsed"]]
    res <- keep_warnings(if (source == "simulator") {
      refine(plain[[key]], tyre_simulator, contact = contact, max_runs = max_runs,
             seed = seeds[["refine"]], progress = FALSE)
    } else {
      refine(plain[[key]], max_runs = max_runs, seed = seeds[["refine"]], progress = FALSE)
    })
    elapsed <- proc.time()[["elapsed"]] - t0
    rec <- refined_record(res$value, res$warnings, elapsed)
    if (source == "emulator") rec$emulator_check <- emulator_check(res$value, contact)
    refined[[key]][[source]] <- rec
    cat(key, "refined with", source, ":", rec$runs_added, "runs,", rec$rounds, "rounds,",
        rec$reason, ",", format(elapsed, digits = 3), "s\n")
    rm(res)
  }
}

# How smooth is the simulator's misfit at the scale refine() reaches? The
# mean squared misfit (N^2) along k at 0.05 N/mm steps, c fixed: patch
# contact to the Fiala data around the truth, disc contact to the PAC2002
# data around the simulator-refined median; each with the library's RK4 step
# and with a step 4 times smaller (not used anywhere else).
misfit_line <- function(contact, data_model, k0, c0, steps_per_sample) {
  ks <- k0 + seq(-1, 1, by = 0.05)
  y <- tyre_cleat_model(cbind(k = ks, c = c0), height = lib$x$height, contact = contact,
                        rig = tyre_rig(steps_per_sample = steps_per_sample))
  y_field <- as.vector(t(field[[data_model]]$y))
  data.table::data.table(contact = contact, data = data_model, steps_per_sample = steps_per_sample,
                         k = ks, c = c0,
                         mean_sq_misfit = rowMeans((y - matrix(y_field, nrow(y), ncol(y),
                                                               byrow = TRUE))^2))
}
disc_med <- refined$pac2002_disc_independent$simulator$summary
rk4_steps <- tyre_rig()$steps_per_sample * c(1, 4)
misfit_lines <- data.table::rbindlist(c(
  lapply(rk4_steps, function(s) misfit_line("patch", "fiala", truth[["k"]], truth[["c"]], s)),
  lapply(rk4_steps, function(s) {
    misfit_line("disc", "pac2002", round(disc_med$median[disc_med$parameter == "k"], 1),
                round(disc_med$median[disc_med$parameter == "c"], 3), s)
  })))
rm(plain)

t_total <- proc.time()[["elapsed"]] - t_script
ch5 <- list(
  settings = list(seeds = seeds, truth = truth, noise_sd = noise_sd, n_iter = n_iter,
                  burn_in = burn_in, chains = chains, phi = phi, rho_t_grid = rho_t_grid,
                  sens_height = sens_height, heights = lib$x$height,
                  step_k = step_k, step_c = step_c, max_runs = max_runs,
                  sim_cost = sim_cost, patch_length = patch_length),
  sensitivity = sensitivity,
  contact_runs = contact_runs,
  design = data.table::data.table(k = round(lib$theta$k, 3), c = round(lib$theta$c, 5)),
  fits = fits,
  refined = refined,
  misfit_lines = misfit_lines,
  timings = c(library = t_library, library_disc = t_library_disc, total = t_total),
  session = list(r = R.version.string, griddy = as.character(utils::packageVersion("griddy")),
                 date = format(Sys.Date())))
out <- file.path("inst", "extdata", "ch5.rds")
saveRDS(ch5, out, compress = "xz")
cat("library build", format(t_library, digits = 3), "s; whole script",
    format(t_total, digits = 3), "s; wrote", out, format(file.size(out) / 1024, digits = 3),
    "KiB\n")
