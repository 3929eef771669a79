# Two modes in two parameters (issue 24): an aliased damped oscillator,
# y = exp(-c t / 20) sin(w t) at t = k pi / 2, k = 1..80, noise sd 0.03, so
# that w and w + 4 give the same data and the posterior has two modes of
# equal mass. theta = (w, c) in [1, 7] x [0.5, 2]; a 3,000-run Latin
# hypercube library; truths w in [1.5, 2.5], c in [0.8, 1.7].
# `refine(fit, simulator, max_runs = 4000)`; `mass_upper` is the refined
# posterior's mass on the mode at w + 4 (0.5 exactly), `covers` whether the
# 95% interval of w holds the truth, `warned` whether refine() warned.
# Run: Rscript bench/aliased-modes.R [trials]; GRIDDY_SRC=<dir> loads
# another source tree (e.g. an export of main, to compare); writes
# bench/results/aliased-modes<GRIDDY_TAG>.csv.
args <- commandArgs(trailingOnly = TRUE)
n_trials <- if (length(args) >= 1) as.integer(args[1]) else 6L
src <- Sys.getenv("GRIDDY_SRC", ".")
pkgload::load_all(src, quiet = TRUE)
tt <- (1:80) * pi / 2
sim <- function(theta) {
  th <- as.matrix(theta)
  t(vapply(seq_len(nrow(th)), function(i) exp(-th[i, 2] * tt / 20) * sin(th[i, 1] * tt),
           numeric(length(tt))))
}
lhs <- function(n, lower, upper, names) {
  u <- matrix(vapply(seq_along(lower), function(j) (sample.int(n) - runif(n)) / n,
                     numeric(n)), n)
  stats::setNames(as.data.frame(sweep(sweep(u, 2, upper - lower, "*"), 2, lower, "+")), names)
}
set.seed(7)
theta <- lhs(3000, c(1, 0.5), c(7, 2), c("w", "c"))
lib <- sim_library(theta, sim(theta))
res <- do.call(rbind, lapply(seq_len(n_trials), function(i) {
  set.seed(100 + i)
  truth <- c(w = runif(1, 1.5, 2.5), c = runif(1, 0.8, 1.7))
  y <- sim(as.data.frame(t(truth)))[1, ] + rnorm(length(tt), sd = 0.03)
  fit <- suppressWarnings(calibrate(lib, field_data(matrix(y, 1), t = lib$t), n_iter = 1000,
                                    burn_in = 200, seed = i))
  warned <- FALSE
  t0 <- proc.time()[["elapsed"]]
  r <- withCallingHandlers(suppressMessages(refine(fit, sim, max_runs = 4000, seed = i)),
                           griddy_warning_resolution = function(w) {
                             warned <<- TRUE
                             invokeRestart("muffleWarning")
                           })
  secs <- proc.time()[["elapsed"]] - t0
  tab <- resolution_limited(r)
  w <- lib_theta(r$library)$w[r$draws$run]
  data.frame(trial = i, w = truth[["w"]], mass_upper = mean(w > truth[["w"]] + 2),
             lower = tab$lower[1], upper = tab$upper[1],
             covers = tab$lower[1] <= truth[["w"]] & truth[["w"]] <= tab$upper[1],
             effective_runs = if (is.null(tab$effective_runs)) NA else tab$effective_runs[1],
             runs_added = if (is.null(r$refinement)) 0L else r$refinement$runs_added,
             reason = if (is.null(r$refinement)) "already resolved" else r$refinement$reason,
             warned = warned, seconds = secs,
             machine = paste("load", readLines("/proc/loadavg")))
}))
print(res, digits = 3)
cat("both modes (mass on each 0.3-0.7):", sum(abs(res$mass_upper - 0.5) < 0.2), "of", nrow(res),
    "; a mode lost without a warning:", sum(abs(res$mass_upper - 0.5) >= 0.2 & !res$warned), "\n")
data.table::fwrite(res, file.path("bench/results",
                                  paste0("aliased-modes", Sys.getenv("GRIDDY_TAG"), ".csv")))
