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
# inst/extdata/real_time.rds (xz-compressed, a few tens of kB), which the
# vignette reads; nothing there is computed at knit time. Then (issue 34,
# item 3) the rig chooses its next cleat by next_measurement() against two
# fixed schedules, over 20 noise seeds per true contact (see "Where to
# measure next" below), stored in real_time$choice.
#
# Run from the package root after installing griddy:
#   R_LIBS=<private lib> Rscript data-raw/real-time.R
# Took 421 s on a shared 2-core machine at load about 2 (the libraries about
# 90 s, the schedules the rest, most of it ranking 20 candidates per step).

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

# Where to measure next (issue 34, item 3): the rig chooses its next cleat
# height. Here the tyre is measured with one contact throughout (the true
# model: patch, then again disc), 20 noise seeds each. At every step the
# candidates are the next not-yet-measured t (in the same every-5th-sample
# order) at each cleat height; "chosen" measures the first row of
# next_measurement(m, cands, about = "model"), "low then high" is the
# schedule above (the whole low pass, then the high one), "alternating"
# takes the two heights in turn. "chosen, skipping" may also skip ahead:
# its candidates are the next `window` samples at each cleat, and the
# samples it skips are not measured. All four take the first measurement on
# the low cleat: before it the streams' vague prior on tau gives no proper
# predictive, so next_measurement() has nothing to rank. A fresh pair of exact streams per trial;
# the same measured passes for all schedules of a seed. Count:
# measurements until P(true model) first reaches 0.99 (as
# bench/next-measurement-model-choice.R). P(true model) is stored for the
# first `horizon` measurements; a trial goes on past them until it settles
# (or runs out of the 200 measurements).
choice_seeds <- seeds[["noise"]] + 100L + seq_len(20)
horizon <- 40L
schedules <- c("chosen", "chosen, skipping", "low then high", "alternating")
window <- 10L
choice_trial <- function(true_contact, seed) {
  passes <- list(pass(heights[1], true_contact, seed), pass(heights[2], true_contact, seed + 1000L))
  y_at <- lapply(passes, function(f) f$y[1, keep])
  t_at <- low$t[keep]
  n_t <- length(keep)
  lapply(schedules, function(schedule) {
    m <- do.call(stream_models, new_streams())
    done <- c(0L, 0L)                    # measured so far at each height
    prob <- numeric(0)
    rank_ms <- numeric(0)
    chosen_h <- integer(0)
    settled <- NA_integer_
    for (step in seq_len(2L * n_t)) {
      open <- which(done < n_t)
      if (length(open) == 0L) break      # a skipping schedule can run out of samples
      if (step == 1L || schedule %in% c("low then high", "alternating")) {
        j <- if (step == 1L || schedule == "low then high" || length(open) == 1L) open[1] else
          (step - 1L) %% 2L + 1L
        next_i <- done[j] + 1L
      } else {
        # candidates: the next sample at each cleat, or the next `window`
        reach <- if (schedule == "chosen") 1L else window
        cands <- do.call(rbind, lapply(open, function(h) {
          i <- seq(done[h] + 1L, min(done[h] + reach, n_t))
          data.frame(h = h, i = i, height = heights[h], t = t_at[i])
        }))
        t0 <- Sys.time()
        best <- next_measurement(m, cands[c("height", "t")], about = "model")$candidate[1]
        rank_ms <- c(rank_ms, 1000 * as.numeric(difftime(Sys.time(), t0, units = "secs")))
        j <- cands$h[best]
        next_i <- cands$i[best]
      }
      done[j] <- next_i
      update(m, y = y_at[[j]][done[j]], x = data.frame(height = heights[j]), t = t_at[done[j]])
      p_true <- exp(m$state$log_prob[[true_contact]])
      if (step <= horizon) prob <- c(prob, p_true)
      chosen_h <- c(chosen_h, j)
      if (is.na(settled) && p_true >= 0.99) settled <- step
      if (!is.na(settled) && step >= horizon) break
    }
    list(summary = data.frame(true_contact = true_contact, seed = seed, schedule = schedule,
                              measurements = settled, rank_ms_median = if (length(rank_ms))
                                stats::median(rank_ms) else NA_real_),
         path = data.frame(true_contact = true_contact, seed = seed, schedule = schedule,
                           step = seq_along(prob), prob_true = prob,
                           height = heights[chosen_h[seq_along(prob)]]),
         rank_ms = if (length(rank_ms)) data.frame(schedule = schedule, ms = rank_ms))
  })
}
t_choice <- proc.time()[["elapsed"]]
trials <- unlist(lapply(c("patch", "disc"), function(tc) {
  unlist(lapply(choice_seeds, function(sd) choice_trial(tc, sd)), recursive = FALSE)
}), recursive = FALSE)
# why the chosen schedule is what it is: after the first measurement (low
# cleat, first sample) of the first seed, next_measurement() over the first
# six samples of each cleat, whether or not time order allows them yet
lookahead <- do.call(rbind, lapply(c("patch", "disc"), function(tc) {
  m <- do.call(stream_models, new_streams())
  f <- pass(heights[1], tc, choice_seeds[1])
  update(m, y = f$y[1, keep[1]], x = data.frame(height = heights[1]), t = low$t[keep[1]])
  cands <- expand.grid(t = low$t[keep[1:6]], height = heights)[-1, c("height", "t")]
  cbind(true_contact = tc, next_measurement(m, cands, about = "model"))
}))
choice <- list(
  settle = do.call(rbind, lapply(trials, `[[`, "summary")),
  paths = do.call(rbind, lapply(trials, `[[`, "path")),
  rank_ms = do.call(rbind, lapply(trials, `[[`, "rank_ms")), lookahead = lookahead,
  settings = list(seeds = choice_seeds, horizon = horizon, threshold = 0.99, window = window,
                  schedules = schedules),
  seconds = proc.time()[["elapsed"]] - t_choice)

real_time <- list(
  history = history, choice = choice, final_check = do.call(rbind, final_check), per_height = per_height,
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
print(stats::aggregate(measurements ~ true_contact + schedule, choice$settle,
                       function(v) c(median = stats::median(v), n = length(v)),
                       na.action = na.pass))
print(tapply(choice$rank_ms$ms, choice$rank_ms$schedule, summary))
print(lookahead)
cat("seconds:", real_time$session$script_seconds, "\n")
