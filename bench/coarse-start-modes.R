# Two modes from a coarse start (issue 35, items 2 and 5). Does
# refine(fit, simulator) at its defaults keep both modes of a bimodal system
# when the base library is a coarse grid, or say it did not?
#   osc-64, osc-225: bench/aliased-modes.R's oscillator, y = exp(-c t / 20)
#     sin(w t) at t = k pi / 2 (80 points, noise sd 0.03), so w and w + 4 fit
#     equally; theta = (w, c) in [1, 7] x [0.5, 2] on an 8 x 8 (64-run) or
#     15 x 15 (225-run) grid; truths w in [1.5, 2.5], c in [0.8, 1.7].
#   bimodal-4-81: bench/many-parameters-systems.R's bimodal-4 (th1 folded
#     about 0.5, so th1 and 1 - th1 fit equally) on a 3^4 grid of [0, 1]^4.
#   Unimodal controls (a mode_lost warning there is a false alarm; runs
#   added show what the search round costs): osc-uni-64, the oscillator with
#   w in [1, 5] (the alias outside), and smooth-4-81, smooth-4 on the 3^4 grid.
# Routes: `simulator` (refine(fit, sim)) and `emulator` (refine(fit)).
# Per trial: the refined posterior's mass on each mode (`mass_truth`, within
# a third of the modes' distance of the true mode; `mass_mirror`, the
# same about the other), `both` (each at least 0.1), coverage of every
# parameter's 95% interval, the warnings' classes, runs added, seconds
# (refine() alone, on a machine shared with other jobs: compare ratios).
# Run: Rscript bench/coarse-start-modes.R <system> <route> [trials];
# GRIDDY_SRC=<dir> loads another source tree (the old code), GRIDDY_TAG
# names the result: bench/results/coarse-start-modes-<system>-<route><tag>.csv;
# GRIDDY_LIB=<library> uses an installed build (R CMD INSTALL -l <library>)
args <- commandArgs(trailingOnly = TRUE)
system_name <- if (length(args) >= 1) args[1] else "osc-64"
route <- if (length(args) >= 2) args[2] else "simulator"
n_trials <- if (length(args) >= 3) as.integer(args[3]) else 20L
first_trial <- if (length(args) >= 4) as.integer(args[4]) else 1L
src <- Sys.getenv("GRIDDY_SRC", ".")
# GRIDDY_LIB=<library>: an installed build (-O2) instead, its internals
# (resolution_limited(), lib_theta()) attached beside it
if (nzchar(Sys.getenv("GRIDDY_LIB"))) {
  library(griddy, lib.loc = Sys.getenv("GRIDDY_LIB"))
  attach(asNamespace("griddy"), name = "griddy_internals", warn.conflicts = FALSE)
} else {
  pkgload::load_all(src, quiet = TRUE)
}
source("bench/many-parameters-systems.R")

oscillator_system <- function(n_side, w_upper = 7) {
  tt <- (1:80) * pi / 2
  sim <- function(theta) {
    th <- as.matrix(theta)
    t(vapply(seq_len(nrow(th)), function(i) exp(-th[i, 2] * tt / 20) * sin(th[i, 1] * tt),
             numeric(length(tt))))
  }
  grid <- expand.grid(w = seq(1, w_upper, length.out = n_side), c = seq(0.5, 2, length.out = n_side))
  list(sim = sim, theta = grid, sd = 0.03, names = c("w", "c"),
       truth = function() c(w = stats::runif(1, 1.5, 2.5), c = stats::runif(1, 0.8, 1.7)),
       mirror_of = function(truth) c(truth[["w"]] + 4, truth[["c"]]), folded = 1L)
}

bimodal_grid_system <- function(p, n_side) {
  sys <- bimodal_system(p)
  axes <- rep(list(seq(0, 1, length.out = n_side)), p)
  grid <- stats::setNames(expand.grid(axes), sys$names)
  inner <- function() {
    truth <- stats::setNames(stats::runif(p, 0.15, 0.85), sys$names)
    truth[1] <- 0.5 + stats::runif(1, 0.15, 0.35)
    truth
  }
  c(sys, list(theta = grid, truth = inner, folded = 1L,
              mirror_of = function(truth) replace(truth, 1, 1 - truth[[1]])))
}

sys <- switch(system_name,
              "osc-64" = oscillator_system(8),
              "osc-225" = oscillator_system(15),
              "bimodal-4-81" = bimodal_grid_system(4, 3),
              # unimodal controls: the alias w + 4 outside the range; smooth-4
              "osc-uni-64" = utils::modifyList(oscillator_system(8, w_upper = 5),
                                               list(mirror_of = NULL)),
              "smooth-4-81" = utils::modifyList(bimodal_grid_system(4, 3),
                                                list(sim = smooth_system(4)$sim, mirror_of = NULL)),
              stop("unknown system ", system_name))
lib <- sim_library(sys$theta, sys$sim(sys$theta))

one <- function(i) {
  set.seed(100 + i)
  truth <- sys$truth()
  y <- sys$sim(as.data.frame(t(truth)))[1, ] + stats::rnorm(ncol(lib$y), sd = sys$sd)
  fit <- suppressWarnings(calibrate(lib, field_data(matrix(y, 1), t = lib$t), n_iter = 1000,
                                    burn_in = 200, seed = i))
  warnings <- character()
  t0 <- proc.time()[["elapsed"]]
  r <- withCallingHandlers(
    suppressMessages(if (route == "simulator") refine(fit, sys$sim, seed = i) else
      refine(fit, seed = i)),
    warning = function(w) {
      cls <- grep("^griddy_warning_", class(w), value = TRUE)
      warnings <<- c(warnings, sub("griddy_warning_", "", cls[cls != "griddy_warning"][1]))
      message("trial ", i, ": ", conditionMessage(w))
      invokeRestart("muffleWarning")
    })
  secs <- proc.time()[["elapsed"]] - t0
  tab <- resolution_limited(r)
  th <- as.matrix(lib_theta(r$library))[r$draws$run, , drop = FALSE]
  j <- sys$folded
  mirror <- if (is.null(sys$mirror_of)) truth else sys$mirror_of(truth)
  gap <- max(abs(mirror[[j]] - truth[[j]]), 1e-9)
  mass_truth <- if (is.null(sys$mirror_of)) NA else mean(abs(th[, j] - truth[[j]]) < gap / 3)
  mass_mirror <- if (is.null(sys$mirror_of)) NA else mean(abs(th[, j] - mirror[[j]]) < gap / 3)
  covered <- tab$lower <= truth & truth <= tab$upper
  # the posterior mean of the other parameters, from the truth in posterior sds
  others <- setdiff(seq_along(truth), j)
  off <- abs(colMeans(th[, others, drop = FALSE]) - truth[others]) /
    pmax(apply(th[, others, drop = FALSE], 2, stats::sd), 1e-12)
  data.frame(system = system_name, route = route, trial = i,
             truth = paste(format(truth, digits = 4), collapse = " "),
             mass_truth = mass_truth, mass_mirror = mass_mirror,
             both = mass_truth >= 0.1 & mass_mirror >= 0.1,
             covered = sum(covered), parameters = length(covered),
             missed = paste(tab$parameter[!covered], collapse = " "),
             worst_sd_off = max(off),
             warned = length(warnings) > 0L, warnings = paste(unique(warnings), collapse = " "),
             runs_added = if (is.null(r$refinement)) 0L else r$refinement$runs_added,
             reason = if (is.null(r$refinement)) "already resolved" else r$refinement$reason,
             seconds = secs, machine = paste("load", readLines("/proc/loadavg")))
}

out <- file.path("bench/results", paste0("coarse-start-modes-", system_name, "-", route,
                                         Sys.getenv("GRIDDY_TAG"), ".csv"))
res <- NULL
for (i in seq(first_trial, length.out = n_trials)) {
  row <- one(i)
  print(row[, c("trial", "mass_truth", "mass_mirror", "covered", "warnings", "runs_added",
                "reason", "seconds")], digits = 3)
  res <- rbind(res, row)
  data.table::fwrite(res, out)
}
cat(system_name, route, ": both modes (each >= 0.1) in", sum(res$both), "of", nrow(res),
    "; one lost unwarned:", sum(!res$both & !res$warned), "; warned:", sum(res$warned), "; coverage",
    sum(res$covered), "of", sum(res$parameters), "\n")
