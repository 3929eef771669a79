# Coverage study for the vignette "Between the runs" (vignettes/between-the-runs.Rmd):
# how often the 95% intervals of a fit on a coarse library hold a truth that
# lies between its runs, and how wide they are, for
#   plain      calibrate() on the coarse 12 x 7 grid (84 runs),
#   fine grid  calibrate() on a uniform 49 x 26 grid (1,274 runs),
#   simulator  refine() of the plain fit with the simulator,
#   emulator   refine() of the plain fit without it (the library's emulator),
#   simulator, 1000 a round / emulator, 1000 a round: the same with
#              runs_per_round = 1000 and max_runs = 3000,
#   continuous the continuous posterior, from a dense 161 x 161 grid of
#              simulator runs: the reference.
# System: the damped oscillator y = a exp(-c t) sin(k t), theta = (k, c) over
# [1, 5] x [0.1, 1], at 4 amplitudes a x 60 times (240 data points), noise
# sd 0.05 (the oscillator of bench/between-the-runs.R). Each trial draws a
# truth uniformly over the middle 80% of both ranges and new noise.
#
# Every interval is the 95% central interval of the exact posterior marginal
# (posterior_exact() on the fit's library: no Monte Carlo error), by the rule
# of summary()'s resolution table: the smallest library value whose
# cumulative mass reaches 2.5%, and 97.5%.
#
# The dense grid spans +-8 sd of the continuous posterior (the Laplace sd at
# the truth with the true noise) around the truth, so that it holds the whole
# posterior; its spacing is 0.1 sd. The script records the posterior mass on
# the grid's border, which must be negligible.
#
# For each refined fit, refine_warned records whether refine() warned (class
# griddy_warning_resolution: it stopped at max_runs before the posterior was
# resolved) and refine_warning the parameters the warning names, with why
# (NA for the other modes).
#
# Run from the package root, with griddy installed:
#   Rscript data-raw/between-the-runs.R   (single core, about 8 minutes on a shared
#   2-core machine; the run time is stored in the .rds)
# BTR_TRIALS sets the number of trials (default 500). Writes
# inst/extdata/between_the_runs.rds.

library(griddy)
started <- proc.time()[["elapsed"]]
n_trials <- as.integer(Sys.getenv("BTR_TRIALS", "500"))

# ---- the system (the same code as in the vignette) ------------------------------
times <- seq(0.05, 3, length.out = 60)
amplitudes <- data.frame(a = c(0.5, 1, 1.5, 2))
oscillator <- function(theta) {
  wave <- exp(-outer(theta$c, times)) * sin(outer(theta$k, times))
  do.call(cbind, lapply(amplitudes$a, function(a) a * wave))
}
noise_sd <- 0.05
k_range <- c(1, 5)
c_range <- c(0.1, 1)

grid_library <- function(n_k, n_c) {
  theta <- expand.grid(k = seq(k_range[1], k_range[2], length.out = n_k),
                       c = seq(c_range[1], c_range[2], length.out = n_c))
  sim_library(theta, oscillator(theta), x = amplitudes, t = times)
}
coarse <- grid_library(12, 7)
fine <- grid_library(49, 26)

# ---- intervals ------------------------------------------------------------------
# The 95% central interval of each parameter's exact marginal over a library's
# values.
exact_intervals <- function(library, field) {
  p <- posterior_exact(library, field)$run
  theta <- library$theta
  t(vapply(c("k", "c"), function(j) {
    m <- tapply(p, theta[[j]], sum)
    v <- as.numeric(names(m))
    cm <- cumsum(m)
    c(lower = v[which(cm >= 0.025)[1]], upper = v[which(cm >= 0.975)[1]])
  }, numeric(2)))
}

# The continuous posterior's sd at the truth (Laplace: Jacobian by central
# differences, true noise sd), for placing the dense grid.
laplace_sd <- function(truth) {
  h <- c(k = 1e-5, c = 1e-5)
  J <- vapply(c("k", "c"), function(j) {
    up <- truth; dn <- truth
    up[[j]] <- up[[j]] + h[[j]]; dn[[j]] <- dn[[j]] - h[[j]]
    (oscillator(up) - oscillator(dn))[1, ] / (2 * h[[j]])
  }, numeric(240))
  sqrt(diag(solve(crossprod(J)))) * noise_sd
}

# The continuous posterior (uniform prior on theta, the package's vague prior
# on tau) on a dense grid around the truth: the griddy posterior of a library
# that resolves it by a wide margin.
continuous_intervals <- function(truth, field) {
  sd <- laplace_sd(truth)
  axes <- Map(function(v, s) v + seq(-8, 8, length.out = 161) * s, truth, sd)
  theta <- expand.grid(axes)
  lib <- sim_library(theta, oscillator(theta), x = amplitudes, t = times)
  p <- posterior_exact(lib, field)$run
  border <- theta$k %in% range(axes$k) | theta$c %in% range(axes$c)
  list(intervals = exact_intervals(lib, field), border_mass = sum(p[border]), sd = sd)
}

# ---- one trial ---------------------------------------------------------------------
one_trial <- function(i) {
  set.seed(20261123 + i)
  truth <- data.frame(k = runif(1, 1.4, 4.6), c = runif(1, 0.19, 0.91))
  y <- oscillator(truth)[1, ] + rnorm(240, sd = noise_sd)
  field <- field_data(matrix(y, 4, byrow = TRUE), x = amplitudes, t = times)
  # griddy's resolution warning (calibrate(): the library limits an interval;
  # refine(): it stopped at max_runs before the posterior was resolved) is
  # recorded, with the parameters it names and why, then muffled
  timed <- function(expr) {
    t0 <- proc.time()[["elapsed"]]
    why <- NA_character_
    value <- suppressMessages(withCallingHandlers(expr, griddy_warning_resolution = function(w) {
      why <<- sub("\\. Call refine\\(\\).*$", "",
                  sub("^.*may miss the truth: ", "", conditionMessage(w)))
      invokeRestart("muffleWarning")
    }))
    list(value = value, seconds = proc.time()[["elapsed"]] - t0, why = why)
  }
  plain <- timed(calibrate(coarse, field, n_iter = 1000, burn_in = 200, seed = i))
  fit <- plain$value
  warned <- !is.na(plain$why)
  fine_warned <- !is.na(timed(calibrate(fine, field, n_iter = 1000, burn_in = 200,
                                        seed = i))$why)
  sim <- timed(refine(fit, oscillator, seed = i))
  emu <- timed(refine(fit, seed = i))
  sim_big <- timed(refine(fit, oscillator, runs_per_round = 1000, max_runs = 3000, seed = i))
  emu_big <- timed(refine(fit, runs_per_round = 1000, max_runs = 3000, seed = i))
  refined <- function(r) {
    list(iv = exact_intervals(r$value$library, field),
         runs = 84L + r$value$refinement$runs_added,
         reason = r$value$refinement$reason, secs = r$seconds,
         limited = any(summary(r$value)$resolution %in% "limited"),
         warned = !is.na(r$why), why = r$why)
  }
  cont <- continuous_intervals(truth, field)
  modes <- list(
    plain = list(iv = exact_intervals(coarse, field), runs = 84L, reason = NA, secs = NA,
                 limited = warned, warned = NA, why = NA),
    "fine grid" = list(iv = exact_intervals(fine, field), runs = 1274L, reason = NA,
                       secs = NA, limited = fine_warned, warned = NA, why = NA),
    simulator = refined(sim),
    emulator = refined(emu),
    "simulator, 1000 a round" = refined(sim_big),
    "emulator, 1000 a round" = refined(emu_big),
    continuous = list(iv = cont$intervals, runs = 161L^2, reason = NA, secs = NA,
                      limited = FALSE, warned = NA, why = NA))
  width_cont <- cont$intervals[, "upper"] - cont$intervals[, "lower"]
  do.call(rbind, lapply(names(modes), function(m) {
    iv <- modes[[m]]$iv
    data.frame(trial = i, mode = m, parameter = c("k", "c"), truth = unlist(truth),
               lower = iv[, "lower"], upper = iv[, "upper"],
               covered = iv[, "lower"] <= unlist(truth) & unlist(truth) <= iv[, "upper"],
               width_ratio = (iv[, "upper"] - iv[, "lower"]) / width_cont,
               posterior_sd = cont$sd, limited = modes[[m]]$limited,
               runs = modes[[m]]$runs, reason = modes[[m]]$reason,
               refine_warned = modes[[m]]$warned, refine_warning = modes[[m]]$why,
               seconds = modes[[m]]$secs, border_mass = cont$border_mass,
               row.names = NULL)
  }))
}

trials <- do.call(rbind, lapply(seq_len(n_trials), function(i) {
  if (i %% 20 == 0) message("trial ", i, " of ", n_trials)
  one_trial(i)
}))
trials$mode <- factor(trials$mode, levels = c("plain", "fine grid", "simulator", "emulator",
                                              "simulator, 1000 a round",
                                              "emulator, 1000 a round", "continuous"))
trials$parameter <- factor(trials$parameter, levels = c("k", "c"))

run_time <- proc.time()[["elapsed"]] - started
out <- list(
  trials = trials,
  settings = list(n_trials = n_trials, noise_sd = noise_sd, k_range = k_range,
                  c_range = c_range, truth_range = list(k = c(1.4, 4.6), c = c(0.19, 0.91)),
                  coarse = "12 x 7 grid", fine = "49 x 26 grid",
                  dense = "161 x 161 grid over +-8 sd around the truth",
                  refine = paste("refine() defaults: max_runs = 1000, runs_per_round = 200;",
                                 "'1000 a round': runs_per_round = 1000, max_runs = 3000")),
  run_time = run_time,
  load_average = tryCatch(readLines("/proc/loadavg"), error = function(e) NA_character_),
  session = c(R.version.string, paste("griddy", utils::packageVersion("griddy")),
              paste("RobustGaSP", tryCatch(as.character(utils::packageVersion("RobustGaSP")),
                                           error = function(e) "not installed"))),
  date = format(Sys.Date()))
saveRDS(out, "inst/extdata/between_the_runs.rds", compress = "xz")

print(merge(aggregate(covered ~ mode + parameter, trials, mean),
            aggregate(width_ratio ~ mode + parameter, trials, median)))
message("run time ", round(run_time), " s")
