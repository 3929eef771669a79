# Accuracy and cost of the library emulator's methods (R/library_emulator*.R),
# to choose what method = "auto" takes.
#
# Three smooth simulators with many outputs:
#   projectile  height of a projectile with linear drag at 50 times,
#               theta = (v0, angle, drag), closed form;
#   piston      griddy's piston stand-in (piston_model()), 27 locations x
#               2 operating conditions = 54 outputs, theta = the three
#               heat-transfer coefficients over table 3.1's ranges (3 decades);
#   oscillator  a damped oscillation A exp(-c t) cos(w t + phi) at 50 times,
#               theta = (w, c, A, phi): four parameters, 4^4 = 256-run stencils.
# Each on a full-factorial grid and on a Latin hypercube (maximin of 20
# random ones) of a few hundred and of about 1,300 runs; 300 held-out points
# drawn uniformly over the library's range (the range of its runs). For each method: the held-out
# error as the RMS over outputs of (RMSE of the output / its sd over the
# held-out points), the same for the leave-one-out residuals
# (emulator_loo()), and the seconds to build and to predict the 300 points.
# "gp" fits on max_runs = 400 runs (the default) and, on the larger Latin
# hypercubes, on all of them ("gp, all runs"; about 150 s a fit). Then the refinement's case: a finer grid
# (21^3, 11^4) and an LHS as large, with the emulators built for a region
# three grid cells wide and the held-out points drawn in it.
#
# Then timings at the thesis's working size: a 39^3 = 59,319-run grid with 54
# outputs (thesis_response(), as the other benchmarks; the time does not
# depend on the values), 1,000 predictions over the whole grid and over a
# region, leave-one-out over the whole grid; and a 60,000-run random design
# with a region, for "gp" and "local".
#
# Usage, from the package root (loads the source, the emulator is internal):
#   Rscript bench/emulator-accuracy.R
# Writes bench/results/emulator-accuracy.csv and prints the tables that
# bench/results/emulator-accuracy.md reports.
suppressPackageStartupMessages(pkgload::load_all(".", quiet = TRUE))
source("bench/helpers.R")
note <- machine_note()

# ---- the simulators --------------------------------------------------------

projectile <- list(
  name = "projectile",
  ranges = data.frame(parameter = c("v0", "angle", "drag"), min = c(10, 15, 0.05),
                      max = c(40, 75, 1)),
  f = function(th) {
    t <- seq(0.1, 4, length.out = 50)
    g <- 9.81
    v_up <- th[, 1] * sin(th[, 2] * pi / 180)
    k <- th[, 3]
    (v_up + g / k) / k * (1 - exp(-outer(k, t))) - outer(g / k, t)
  }
)

piston <- list(
  name = "piston",
  ranges = piston_htc_ranges()[, c("parameter", "min", "max")],
  f = function(th) unname(piston_model(th, condition = c("full", "part")))
)

oscillator <- list(
  name = "oscillator",
  ranges = data.frame(parameter = c("w", "c", "A", "phi"), min = c(1, 0.05, 0.5, 0),
                      max = c(2, 0.5, 2, pi / 2)),
  f = function(th) {
    t <- seq(0, 4, length.out = 50)
    th[, 3] * exp(-outer(th[, 2], t)) * cos(outer(th[, 1], t) + th[, 4])
  }
)

# ---- designs ---------------------------------------------------------------

design_grid <- function(ranges, n_per_dim) {
  axes <- lapply(seq_len(nrow(ranges)), function(j) {
    seq(ranges$min[j], ranges$max[j], length.out = n_per_dim)
  })
  names(axes) <- ranges$parameter
  as.matrix(expand.grid(axes, KEEP.OUT.ATTRS = FALSE))
}

# The best by smallest distance of 20 random Latin hypercubes (one, beyond
# 2,000 runs, where the distances would not fit in memory).
design_lhs <- function(ranges, n, seed) {
  set.seed(seed)
  one <- function() vapply(seq_len(nrow(ranges)), function(j) (sample(n) - runif(n)) / n,
                           numeric(n))
  best <- one()
  if (n <= 2000) {
    best_d <- min(stats::dist(best))
    for (i in 2:20) {
      u <- one()
      if (min(stats::dist(u)) > best_d) {
        best <- u
        best_d <- min(stats::dist(u))
      }
    }
  }
  out <- best * rep(ranges$max - ranges$min, each = n) + rep(ranges$min, each = n)
  colnames(out) <- ranges$parameter
  out
}

design_uniform <- function(ranges, n, seed) {
  set.seed(seed)
  out <- vapply(seq_len(nrow(ranges)), function(j) runif(n, ranges$min[j], ranges$max[j]),
                numeric(n))
  colnames(out) <- ranges$parameter
  out
}

# RMS over outputs of (RMSE / sd of the output over the held-out points).
rel_rmse <- function(err, sd_out) {
  keep <- sd_out > 0
  sqrt(mean((sqrt(colMeans(err[, keep, drop = FALSE]^2)) / sd_out[keep])^2))
}

# ---- accuracy ----------------------------------------------------------------

# `region`: NULL for the whole library, else a 2 x p box in which the
# emulators are built and the held-out points drawn (the refinement's case).
one_case <- function(sim, design, theta, region = NULL) {
  y <- sim$f(theta)
  lib <- sim_library(theta, y)
  # held out over the library's range (or the region): a Latin hypercube
  # stops short of the nominal bounds, and the emulator does not extrapolate
  box <- if (is.null(region)) rbind(apply(theta, 2, min), apply(theta, 2, max)) else region
  test <- design_uniform(data.frame(min = box[1, ], max = box[2, ]), 300, seed = 99)
  y_test <- sim$f(test)
  sd_out <- apply(y_test, 2, sd)
  methods <- list(local = list(method = "local"), gp = list(method = "gp"))
  if (nrow(theta) > 400 && is.null(region) && !grepl("grid", design)) {
    methods[["gp, all runs"]] <- list(method = "gp", max_runs = nrow(theta))
  }
  if (grepl("grid", design)) methods <- c(list(grid = list(method = "grid")), methods)
  rows <- lapply(names(methods), function(label) {
    build_s <- time_it(em <- do.call(library_emulator,
                                     c(list(lib, region = region), methods[[label]])))
    predict_s <- time_it(pred <- emulator_predict(em, test))
    loo <- emulator_loo(em)
    data.frame(simulator = sim$name, design = design, runs = nrow(theta),
               region = !is.null(region), method = label, runs_used = length(em$rows),
               holdout_rel_rmse = rel_rmse(pred$outputs - y_test, sd_out),
               loo_rel_rmse = rel_rmse(loo$residuals, sd_out),
               build_s = build_s, predict_300_s = predict_s)
  })
  out <- do.call(rbind, rows)
  print(out, digits = 3)
  out
}

# A region around `centre` (fractions of the ranges), `width` wide in each.
region_at <- function(ranges, centre, width) {
  lo <- ranges$min + (ranges$max - ranges$min) * (centre - width / 2)
  hi <- ranges$min + (ranges$max - ranges$min) * (centre + width / 2)
  out <- rbind(lo, hi)
  colnames(out) <- ranges$parameter
  out
}

# simulator, grid values per parameter and LHS runs for the whole library;
# then a finer grid (and an LHS as large) with a region 3 grid cells wide.
cases <- list(
  list(projectile, 7, 343), list(projectile, 11, 1331),
  list(piston, 7, 343), list(piston, 11, 1331),
  list(oscillator, 5, 625), list(oscillator, 6, 1296)
)
region_cases <- list(
  list(projectile, 21, c(0.4, 0.6, 0.3)),
  list(piston, 21, (piston_htc_ranges()$true - piston$ranges$min) /
         (piston$ranges$max - piston$ranges$min)),
  list(oscillator, 11, c(0.5, 0.3, 0.6, 0.4))
)
set.seed(1)
accuracy <- do.call(rbind, c(lapply(cases, function(cs) {
  sim <- cs[[1]]
  rbind(one_case(sim, paste0("grid ", cs[[2]], "^", nrow(sim$ranges)),
                 design_grid(sim$ranges, cs[[2]])),
        one_case(sim, "LHS", design_lhs(sim$ranges, cs[[3]], seed = cs[[3]])))
}), lapply(region_cases, function(cs) {
  sim <- cs[[1]]
  n <- cs[[2]]
  region <- region_at(sim$ranges, cs[[3]], 3 / (n - 1))
  rbind(one_case(sim, paste0("grid ", n, "^", nrow(sim$ranges)),
                 design_grid(sim$ranges, n), region),
        one_case(sim, "LHS", design_lhs(sim$ranges, n^nrow(sim$ranges), seed = n), region))
})))
accuracy$machine <- note

# ---- timings at the thesis's size ------------------------------------------

timing <- list()
time_row <- function(case, what, seconds) {
  timing[[length(timing) + 1L]] <<- data.frame(case = case, what = what, seconds = seconds)
  cat(sprintf("%-45s %-40s %8.3f s\n", case, what, seconds))
}
locations <- seq(0, 1, length.out = 54)
theta <- as.matrix(thesis_theta(n_per_dim = 39))
big <- sim_library(theta, thesis_response(theta, locations))
new_all <- design_uniform(data.frame(min = apply(theta, 2, min), max = apply(theta, 2, max)),
                          1000, seed = 5)
region <- rbind(c(800, 2700, 1700), c(1200, 3300, 2300))
colnames(region) <- colnames(theta)
new_region <- design_uniform(data.frame(min = region[1, ], max = region[2, ]), 1000, seed = 6)
colnames(new_all) <- colnames(new_region) <- colnames(theta)
case <- "grid 39^3 (59,319 runs, 54 outputs)"
time_row(case, "library_emulator(), whole library", time_it(em <- library_emulator(big)))
for (i in 1:3) {
  time_row(case, "emulator_predict(), 1,000 points", time_it(emulator_predict(em, new_all)))
}
time_row(case, "emulator_loo(), 59,319 nodes", time_it(emulator_loo(em)))
time_row(case, "library_emulator(), region", time_it(em <- library_emulator(big, region)))
time_row(case, "emulator_predict(), 1,000 points in region",
         time_it(emulator_predict(em, new_region)))
time_row(case, paste0("runs read for the region: ", length(em$rows)), NA)

theta <- as.matrix(thesis_theta(n_runs = 60000, seed = 3))
big <- sim_library(theta, thesis_response(theta, locations))
case <- "random 60,000 runs, 54 outputs, region"
for (m in c("gp", "local")) {
  time_row(case, paste0("library_emulator(\"", m, "\")"),
           time_it(em <- library_emulator(big, region, method = m)))
  time_row(case, paste0("emulator_predict(\"", m, "\"), 1,000 points"),
           time_it(emulator_predict(em, new_region)))
  time_row(case, paste0("emulator_loo(\"", m, "\"), ", length(em$rows), " runs"),
           time_it(emulator_loo(em)))
}
timing <- do.call(rbind, timing)
timing$machine <- note

dir.create("bench/results", showWarnings = FALSE)
utils::write.csv(accuracy, "bench/results/emulator-accuracy.csv", row.names = FALSE)
utils::write.csv(timing, "bench/results/emulator-timing.csv", row.names = FALSE)

cat("\n", note, "\n\n", sep = "")
cat("| simulator | design | runs | region | method | runs used | held-out rel. RMSE |",
    " LOO rel. RMSE | build (s) | predict 300 (s) |\n",
    "|---|---|---:|---|---|---:|---:|---:|---:|---:|\n", sep = "")
with(accuracy, cat(sprintf("| %s | %s | %d | %s | %s | %d | %.2g | %.2g | %.2f | %.3f |\n",
                           simulator, design, runs, ifelse(region, "yes", "no"), method,
                           runs_used, holdout_rel_rmse, loo_rel_rmse, build_s,
                           predict_300_s), sep = ""))
cat("\n| case | what | seconds |\n|---|---|---:|\n")
with(timing, cat(sprintf("| %s | %s | %s |\n", case, what,
                         ifelse(is.na(seconds), "", sprintf("%.3f", seconds))), sep = ""))
