# The "Real time" vignette (issue 25): the tyre stand-in on a drum whose
# cleat is raised during the test, measurements arriving one at a time.
#
# Two libraries of the same Fiala tyre over (k, c), one per contact model:
# the rectangular patch (the thesis's Fiala assumption) and the rigid
# disc (the contact of the thesis's PAC2002 runs), each at the two cleat
# heights of the test (12.13 mm, then 41.2 mm). The "measured" tyre is the stand-in's PAC2002-style tyre at
# k = 450 N/mm, c = 1.5 N s/mm with noise (sd 60 N), as in chapter 5, with
# the patch contact on the first cleat. To show a change of regime, the
# data after the cleat change are made with the rigid disc instead: a
# constructed change (in the stand-in the better contact model does not
# depend on the cleat height; the per-height evidences stored below show
# it). Every 5th sample of each 0.5 s pass (100 per pass) arrives, in time
# order, first the pass over the low cleat, then over the high one.
#
# Four streams take the 200 measurements (one per contact model for the
# exact model probabilities, one per model for dynamic model averaging with
# forgetting 0.95); after each measurement the script stores both model
# probabilities, each model's exact posterior mean and 95% interval of k and
# c, its effective number of runs, and the time of the update (the whole R
# call: the streams' updates and their evidences). Everything lands in
# inst/extdata/real_time.rds (xz-compressed, a few kB), which the vignette
# reads; nothing there is computed at knit time.
#
# Run from the package root after installing griddy:
#   R_LIBS=<private lib> Rscript data-raw/real-time.R
# Took 112 s on a shared 2-core machine at load about 2 (mostly the libraries).

library(griddy)
t_script <- proc.time()[["elapsed"]]
seeds <- c(library = 2025, noise = 25)
n_runs <- 1500
heights <- tyre_cleat_heights()[c(3, 1)]   # 12.13 mm, then 41.2 mm
truth <- c(k = 450, c = 1.5)
noise_sd <- 60                             # N: 2% of the 3 kN static load, as chapter 5
every <- 5                                 # every 5th sample arrives
forgetting <- 0.95
# AR(1) over time on t scaled to [0, 1] over the 500 samples: lag-one
# correlations 0, 0.5 and 0.9 at 1 ms
rho_t <- c(0, 0.5^499, 0.9^499)

libs <- list()
for (contact in c("patch", "disc")) {
  set.seed(seeds[["library"]])
  libs[[contact]] <- tyre_library(n_runs, height = heights, contact = contact)
}

# the measured passes: patch contact on the low cleat, disc on the high one
pass <- function(height, contact, seed) {
  tyre_field_data(truth[["k"]], truth[["c"]], height = height, model = "pac2002",
                  contact = contact, noise_sd = noise_sd, seed = seed)
}
low <- pass(heights[1], "patch", seeds[["noise"]])
high <- pass(heights[2], "disc", seeds[["noise"]] + 1L)
keep <- seq(every, length(low$t), by = every)
arrivals <- data.frame(height = rep(heights, each = length(keep)),
                       t = c(low$t[keep], high$t[keep]),
                       y = c(low$y[1, keep], high$y[1, keep]),
                       truth_contact = rep(c("patch", "disc"), each = length(keep)))

new_streams <- function() lapply(libs, griddy_stream, rho_t = rho_t)
exact <- do.call(stream_models, new_streams())
dma <- do.call(stream_models, c(new_streams(), list(forgetting = forgetting)))

posterior_row <- function(stream) {
  s <- suppressWarnings(summary(stream))
  c(k_mean = s$mean[1], k_lower = s$lower[1], k_upper = s$upper[1],
    c_mean = s$mean[2], c_lower = s$lower[2], c_upper = s$upper[2],
    effective_runs = attr(s, "effective_runs"))
}
steps <- vector("list", nrow(arrivals))
for (m in seq_len(nrow(arrivals))) {
  x <- data.frame(height = arrivals$height[m])
  t0 <- Sys.time()
  update(exact, y = arrivals$y[m], x = x, t = arrivals$t[m])
  update_ms <- 1000 * as.numeric(difftime(Sys.time(), t0, units = "secs"))
  update(dma, y = arrivals$y[m], x = x, t = arrivals$t[m])
  post <- lapply(exact$streams, posterior_row)
  steps[[m]] <- data.frame(step = m, update_ms = update_ms,
                           t(unlist(lapply(names(post), function(p) {
                             stats::setNames(post[[p]], paste0(p, "_", names(post[[p]])))
                           }))))
}
history <- cbind(arrivals, do.call(rbind, steps)[-1])
h_exact <- as.data.frame(exact)
h_dma <- as.data.frame(dma)
history$prob_patch <- h_exact$prob_patch
history$prob_patch_dma <- h_dma$prob_patch
history$log_pred_patch <- h_exact$log_pred_patch
history$log_pred_disc <- h_exact$log_pred_disc

# checks the vignette reports: the streams against posterior_exact() on all
# the data, and the per-height evidences of each contact model on a pass
# made entirely with each contact
final_check <- lapply(names(libs), function(p) {
  s <- exact$streams[[p]]
  batch <- suppressWarnings(posterior_exact(libs[[p]], field_data(stream_data(s)),
                                            rho_t = rho_t, joint = FALSE))
  data.frame(model = p, max_run_prob_diff = max(abs(posterior_exact(s, joint = FALSE)$run -
                                                      batch$run)),
             log_evidence_stream = as.numeric(logLik(s)),
             log_evidence_batch = batch$log_evidence)
})
per_height <- do.call(rbind, lapply(c("patch", "disc"), function(truth_contact) {
  do.call(rbind, lapply(heights, function(h) {
    f <- pass(h, truth_contact, seeds[["noise"]] + 2L)
    f <- field_data(f$y[1, keep], x = data.frame(height = h), t = f$t[keep])
    ev <- vapply(libs, function(l) {
      suppressWarnings(posterior_exact(l, f, rho_t = rho_t, joint = FALSE))$log_evidence
    }, numeric(1))
    data.frame(truth_contact = truth_contact, height = h,
               log_evidence_patch = ev[["patch"]], log_evidence_disc = ev[["disc"]])
  }))
}))

real_time <- list(
  history = history, final_check = do.call(rbind, final_check), per_height = per_height,
  settings = list(n_runs = n_runs, heights = heights, truth = truth, noise_sd = noise_sd,
                  every = every, forgetting = forgetting, rho_t = rho_t, seeds = seeds,
                  n_t = length(low$t)),
  session = list(date = format(Sys.Date()), griddy = as.character(packageVersion("griddy")),
                 R = R.version.string, cores = parallel::detectCores(),
                 load = readLines("/proc/loadavg"),
                 script_seconds = proc.time()[["elapsed"]] - t_script))
saveRDS(real_time, "inst/extdata/real_time.rds", compress = "xz")
print(real_time$final_check)
print(real_time$per_height)
print(summary(history$update_ms))
cat("seconds:", real_time$session$script_seconds, "\n")
