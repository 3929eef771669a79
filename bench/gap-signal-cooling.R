# Issue 33, item 2: the gap screen's block scan on a system it was not
# designed on. Newton cooling,
#   T(t) = T_env + (T_0 - T_env) exp(-h t),
# at three starting temperatures T_0 = 40, 60, 80 (the x setting), 30 times
# from 0.5 to 10, theta = (h, T_env) on a 121 x 121 grid fine enough to
# resolve the posterior (no resolution warning, so the screen speaks).
# Field data: one experiment (no replicates), noise sd 0.2, theta drawn in
# the middle half of the grid's box. In the gap trials a local transient (a
# door opened: a Gaussian bump of sd 0.4 in t) of 5 noise sds at T_0 = 80
# only, centred anywhere in t from 2 to 9 (drawn per trial, so no window
# placement is favoured). 30 trials without a gap and 15 with.
#
# The rule was fixed on the drug system (bench/gap-signal.R) before this
# script was written and was not changed after it ran. Each trial counts
# calibrate()'s gap warning (class griddy_warning_gap; the default screen,
# whose block checks scan windows of every width at half-steps) and, on the
# same fit, what the former fixed tiling of 8 windows per setting would have
# flagged (base_check() with windows = 8, Benjamini-Hochberg at
# gap_block_fdr, plus the evidence rule).
#
# Run from the package root: Rscript bench/gap-signal-cooling.R (~1 min).
# Results: bench/results/gap-signal-cooling.csv.
pkgload::load_all(".", quiet = TRUE)

times <- seq(0.5, 10, length.out = 30)
starts <- data.frame(T0 = c(40, 60, 80))
cool <- function(h, env) unlist(lapply(starts$T0, function(T0) env + (T0 - env) * exp(-h * times)))
theta <- expand.grid(h = seq(0.295, 0.305, length.out = 121),
                     T_env = seq(19.8, 20.2, length.out = 121))
Y <- t(mapply(cool, theta$h, theta$T_env))
library_cool <- sim_library(theta, Y, x = starts, t = times)
noise_sd <- 0.2

trial <- function(size, seed) {
  set.seed(seed)
  h <- stats::runif(1, 0.2975, 0.3025)
  env <- stats::runif(1, 19.9, 20.1)
  centre <- stats::runif(1, 2, 9)
  y <- matrix(cool(h, env), 3, length(times), byrow = TRUE)
  y[3, ] <- y[3, ] + size * noise_sd * exp(-0.5 * ((times - centre) / 0.4)^2)
  y <- y + stats::rnorm(length(y), sd = noise_sd)
  classes <- character(0)
  fit <- withCallingHandlers(
    calibrate(library_cool, field_data(y, x = starts, t = times), n_iter = 1000,
              burn_in = 200, seed = seed),
    warning = function(w) {
      classes <<- c(classes, class(w)[1])
      invokeRestart("muffleWarning")
    })
  screen <- fit$gap_screen
  tiling <- base_check(fit, 8L, gap_block_fdr, screen_runs(fit$exact$run))$blocks
  data.frame(size = size, seed = seed, h = h, T_env = env, centre = centre,
             warned = "griddy_warning_gap" %in% classes,
             resolution_warned = "griddy_warning_resolution" %in% classes,
             screen_log_bf = screen$log_bf, scan_flagged = screen$n_flagged,
             scan_min_p = min(screen$blocks$p_value, na.rm = TRUE),
             tiling_flagged = sum(tiling$flagged),
             tiling_warns = gap_shown(screen$log_bf, sum(tiling$flagged)))
}

rows <- list()
for (size in c(0, 5)) {
  for (i in seq_len(if (size == 0) 30L else 15L)) {
    rows[[length(rows) + 1L]] <- r <- trial(size, 7000L + 100L * size + i)
    message(sprintf("size %g seed %d: warned %s (bound %.2f, scan %d, tiling %d)", size, r$seed,
                    r$warned, r$screen_log_bf, r$scan_flagged, r$tiling_flagged))
  }
}
out <- do.call(rbind, rows)
dir.create("bench/results", showWarnings = FALSE)
utils::write.csv(out, "bench/results/gap-signal-cooling.csv", row.names = FALSE)
tab <- do.call(rbind, lapply(split(out, out$size), function(d) {
  data.frame(size_sd = d$size[1], trials = nrow(d), calibrate_warns = sum(d$warned),
             tiling_would_warn = sum(d$tiling_warns), resolution_warned = sum(d$resolution_warned))
}))
print(tab, row.names = FALSE)
