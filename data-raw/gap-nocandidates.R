# diagnose_gap(fit) without candidates: false "other" rates on and off the
# library runs, detection of withheld effects, with and without replicates,
# and localised gaps. Run from the package root:
#   Rscript data-raw/gap-nocandidates.R
# Results: inst/extdata/gap_nocandidates_trials.csv (one row per trial).
pkgload::load_all(".", quiet = TRUE)

# osc_sys() with localised gaps: where = "all" (hardening at every amplitude),
# "x3" (hardening at the largest amplitude only), "late" (an extra decaying
# term only for t > 1.3)
osc_loc <- function(n_grid = 21, gap = 0, seed = 1, sd = 0.05, truth = c(w = 6.3, c = 0.83),
                    n_t = 25, reps = 1, where = "all") {
  set.seed(seed)
  t <- seq(0, 2, length.out = n_t)
  x <- data.frame(amp = c(0.5, 1, 1.5))
  sim <- function(w, c, h = 0, where = "all") {
    out <- numeric(0)
    for (a in x$amp) {
      hh <- if (where == "x3" && a != 1.5) 0 else if (where %in% c("late", "x3add")) 0 else h
      v <- a * exp(-c * t) * cos(w * (1 + hh * a^2) * t)
      if (where == "late") v <- v + h * 10 * a * (t > 1.3) * (t - 1.3)
      if (where == "x3add" && a == 1.5) v <- v + h * 4 * sin(pi * t / 2)
      out <- c(out, v)
    }
    out
  }
  theta <- expand.grid(w = seq(5, 8, length.out = n_grid), c = seq(0.3, 1.5, length.out = n_grid))
  Y <- t(mapply(sim, theta$w, theta$c))
  lib <- sim_library(theta, Y, x = x, t = t)
  mu <- sim(truth[1], truth[2], gap, where)
  yy <- do.call(rbind, lapply(seq_len(reps), function(r) {
    matrix(mu + rnorm(length(mu), 0, sd), nrow(x), n_t, byrow = TRUE)
  }))
  field <- if (reps == 1) field_data(yy) else
    field_data(yy, x = x[rep(1:3, reps), , drop = FALSE], t = t)
  list(library = lib, field = field, truth = truth)
}

# truth on the library's runs (a grid node) or between them
truths <- list(on = c(w = 6.35, c = 0.84), off = c(w = 6.3, c = 0.83))
trials <- expand.grid(seed = 1:3, truth = names(truths), gap = c(0, 0.05), reps = c(1, 3),
                      rho = c("0", "0,0.5,0.9"), where = "all", stringsAsFactors = FALSE)
local <- expand.grid(seed = 1:3, truth = "off", gap = 0.05, reps = 1, rho = "0,0.5,0.9",
                     where = c("x3add", "late", "x3"), stringsAsFactors = FALSE)
trials <- rbind(trials, local)
rows <- lapply(seq_len(nrow(trials)), function(i) {
  tr <- trials[i, ]
  s <- osc_loc(gap = tr$gap, seed = tr$seed, reps = tr$reps, truth = truths[[tr$truth]],
               where = tr$where)
  rho_t <- as.numeric(strsplit(tr$rho, ",")[[1]])
  fit <- suppressWarnings(calibrate(s$library, s$field, rho_t = rho_t, n_iter = 500,
                                    burn_in = 100, seed = 1))
  start <- proc.time()[["elapsed"]]
  g <- diagnose_gap(fit, seed = 1, windows = 4)
  wh <- g$where
  top <- wh[which.max(wh$score), ]
  out <- cbind(tr, answer = g$verdict$answer, prob_other = g$which$prob[g$which$effect == "other"],
               log_bf = g$evidence$log_bayes_factor, n_flagged = sum(wh$flagged),
               flagged_x = paste(sort(unique(wh$x[wh$flagged])), collapse = " "),
               flagged_from = if (any(wh$flagged)) min(wh$from[wh$flagged]) else NA,
               top_x = top$x, top_from = top$from, runs = g$settings$runs,
               seconds = proc.time()[["elapsed"]] - start)
  print(out)
  out
})
res <- do.call(rbind, rows)
utils::write.csv(res, "inst/extdata/gap_nocandidates_trials.csv", row.names = FALSE)
