# The thesis's full model (issue 15): correlation over x sampled on a grid.
# The chapter 3-4 piston case, 59,319 runs (39 values per coefficient) x 54
# data points (27 locations x 2 operating conditions), each point with its 3
# coordinates (r, z, condition) as x; one rho_x grid per coordinate with 3, 5
# and 10 values, seq(0, 0.9, length.out = k), every combination (27, 125 and
# 1,000 grid points); 35,000 iterations (burn-in 15,000), one chain, data
# piston_field_data(54, discrepancy = TRUE, seed = 2023). R_x is Appendix A's
# eq. 5, rho^|d| (`x_power = 1`); the cost does not depend on the power.
#
# Side by side in one run, each implementation in its own R process:
#  * old:   griddy as on main before issue 15 (commit c18971b), installed
#           into GRIDDY_OLD_LIB (default /tmp/lib-griddy-old) on first use;
#  * issue: griddy at e0ff0cf, the commit whose figures issue 15 quotes,
#           installed into GRIDDY_ISSUE_LIB (default /tmp/lib-griddy-e0ff0cf);
#           run after old, with which it is compared;
#  * new:   the griddy in GRIDDY_NEW_LIB (default: the installed griddy), once
#           per thread count in GRIDDY_NEW_THREADS (e.g. "1,2"; default the
#           package's own choice), set as option griddy.threads;
#  * plain: the thesis's Appendix A loop in plain R with the same grid
#           (bench/helpers.R: plain_quad_forms_x(), then thesis_plain_r()).
#           PLAIN_MAX_ITER (default 35,000) caps its iterations; its sampling
#           time is then scaled linearly to 35,000 (its cost per iteration is
#           constant), its burn-in is shortened in proportion, and the column
#           plain_iterations says what ran.
# Timed: calibrate() as a whole (precompute = C and the sampler's tables;
# sampling = the chain), for the plain loop C and the loop. Per process: peak
# resident memory during the call above the memory before it (the library
# is in memory before), CPU seconds / elapsed (the cores used), the process's
# threads after the call, the cores other processes kept busy during it (the
# test of a shared machine), and the one-minute load average before it
# (context only: it counts the benchmark's own previous process). Checks: C
# of each implementation against the old code's (largest relative
# difference), the draws identical to the old code's, and the posterior means
# against the old code's in Monte Carlo standard errors (largest |z|).
#
# Usage, from the package root:
#   GRIDDY_NEW_LIB=/tmp/lib-new Rscript bench/rho-x-grid.R
# Options (environment): RHO_X_SIZES (default "3,5,10"), RHO_X_IMPLEMENTATIONS
# (default "issue,old,new,plain"), GRIDDY_NEW_THREADS, PLAIN_MAX_ITER, RHO_X_PER_DIM
# (values per coefficient of the library, default 39; smaller for a smoke test),
# RHO_X_CASE ("piston", the default, or "random": the same runs and data with
# x drawn uniformly on [0, 1]^3 per data point, so that no two points share a
# coordinate; then a grid point with some rho_j = 0 has R_x = I, which every
# version recognises, the case issue 15's figures fit best).
# Writes bench/results/rho-x-grid.csv, rho-x-grid-posterior.csv and
# rho-x-grid.md (rho-x-grid-random.* for the random case). Runtime here: about 15 minutes (old code 2.5 minutes and the
# plain loop about 8 at 1,000 grid points), plus 1-3 minutes to install the old code once.
source("bench/helpers.R")
args <- commandArgs(TRUE)
n_iter <- 35000L
burn_in <- 15000L
rho_values <- function(k) seq(0, 0.9, length.out = k)
thesis_seconds <- 38.8  # Table 4.5, 54 data points (about 40 s at every size)
goal_seconds <- 10      # issue 15: 1,000 grid points
x_case <- Sys.getenv("RHO_X_CASE", "piston")
stopifnot(x_case %in% c("piston", "random"))
result_name <- if (x_case == "piston") "rho-x-grid" else "rho-x-grid-random"

# The piston case's inputs, with x drawn at random in the random case.
case_inputs <- function(per_dim) {
  inputs <- piston_case_inputs(per_dim)
  if (x_case == "random") {
    set.seed(1)
    n <- length(inputs$field_y)
    inputs$x <- data.frame(x1 = runif(n), x2 = runif(n), x3 = runif(n))
  }
  inputs
}

# The case's grids, one per x column.
case_grids <- function(x, k) setNames(rep(list(rho_values(k)), ncol(x)), names(x))

# Child: the inputs (library and field as plain data, so every griddy reads the same).
if (length(args) == 2 && args[1] == "--inputs") {
  suppressPackageStartupMessages(library(griddy))
  saveRDS(case_inputs(as.integer(Sys.getenv("RHO_X_PER_DIM", 39))),  # smaller: smoke test
          file.path(args[2], "inputs.rds"), compress = FALSE)
  quit(save = "no")
}

# Child: one implementation at one grid size; writes <label>-<k>.csv (timings),
# <label>-<k>-posterior.csv, <label>-<k>-draws.rds and <label>-<k>-C.bin.
if (length(args) == 5 && args[1] == "--one") {
  impl <- args[2]
  label <- args[3]
  k <- as.integer(args[4])
  dir <- args[5]
  inputs <- readRDS(file.path(dir, "inputs.rds"))
  grids <- case_grids(inputs$x, k)
  n_runs_case <- nrow(inputs$y)
  load_before <- load_1min()
  base <- file.path(dir, paste0(label, "-", k))
  if (impl == "plain") {
    plain_iter <- min(n_iter, as.integer(Sys.getenv("PLAIN_MAX_ITER", n_iter)))
    set.seed(1)
    t_pre <- 0
    m <- measure_call({
      t_pre <- time_it(pq <- plain_quad_forms_x(inputs$y, inputs$field_y, inputs$x, grids))
      draws <- thesis_plain_r(pq$C, pq$logdet, length(inputs$field_y), plain_iter,
                              round(burn_in * plain_iter / n_iter))
    })
    precompute <- t_pre
    sampling <- (m$elapsed_s - t_pre) * n_iter / plain_iter
    combos <- expand.grid(grids, KEEP.OUT.ATTRS = FALSE)
    names(combos) <- paste0("rho_x_", names(combos))
    kept <- c(as.list(inputs$theta[draws, , drop = FALSE]),
              as.list(combos[attr(draws, "grid_point"), , drop = FALSE]))
    post <- data.frame(parameter = names(kept), mean = vapply(kept, mean, 0),
                       mcse = vapply(kept, function(v) {
                         if (all(v == v[1])) NA_real_ else posterior::mcse_mean(v)
                       }, 0))
    info <- data.frame(griddy_version = "-", griddy_lib = "-", threads_option = "-",
                       griddy_threads = NA_integer_)
    draws_out <- list(run = as.vector(draws), grid_point = attr(draws, "grid_point"))
    C <- pq$C
    C_mb <- as.numeric(object.size(C)) / 2^20
    warnings <- ""
    iterations_run <- plain_iter
    total <- precompute + sampling
  } else {
    suppressPackageStartupMessages(library(griddy))
    info <- griddy_child_setup()
    lib <- case_library(inputs)
    field <- case_field(inputs)
    m <- measure_call(with_warning_classes(
      calibrate(lib, field, rho_x = grids, x_power = 1, n_iter = n_iter, burn_in = burn_in,
                seed = 1, progress = FALSE)))
    fit <- m$value
    precompute <- fit$runtime[["precompute"]]
    sampling <- fit$runtime[["sampling"]]
    s <- as.data.frame(unclass(summary(fit)))
    if (!"mcse" %in% names(s)) s$mcse <- NA_real_  # griddy 0.1.0 (the issue's code) had none
    post <- s[!s$parameter %in% "tau", c("parameter", "mean", "mcse")]
    # griddy 0.1.0 named the grid point `rho` and kept C in the problem
    draws_out <- list(run = fit$draws$run,
                      grid_point = if (is.null(fit$draws$grid_point)) fit$draws$rho else
                        fit$draws$grid_point)
    C <- if (is.null(fit$C)) fit$problem$C else fit$C
    C_mb <- if (is.null(C)) NA_real_ else as.numeric(object.size(C)) / 2^20
    warnings <- attr(fit, "warnings")
    iterations_run <- n_iter
    total <- m$elapsed_s  # the whole call, its checks after sampling included
  }
  data.table::fwrite(post, paste0(base, "-posterior.csv"))
  saveRDS(draws_out, paste0(base, "-draws.rds"))
  # a C that is not a numeric matrix (stored otherwise) is not compared
  C_values <- tryCatch(as.double(C), error = function(e) NULL)
  if (length(C_values) == n_runs_case * k^3) writeBin(C_values, paste0(base, "-C.bin"))
  rm(C_values)
  data.table::fwrite(data.frame(
    implementation = label, rho_values_per_coordinate = k, grid_points = k^3,
    info, calibrate_s = total, precompute_s = precompute,
    sampling_s = sampling, iterations = n_iter, plain_iterations = iterations_run,
    C_mb = C_mb, rss_before_mb = m$rss_before_mb, peak_extra_mb = m$peak_extra_mb,
    peak_mb = m$peak_mb, cpu_s = m$cpu_s * total / m$elapsed_s,
    cpu_per_elapsed = m$cpu_s / m$elapsed_s, os_threads = m$os_threads,
    other_cores = m$other_cores, load_1min = load_before, warnings = warnings), paste0(base, ".csv"))
  quit(save = "no")
}

# Parent: run every implementation at every size, compare, write the results.
sizes <- as.integer(strsplit(Sys.getenv("RHO_X_SIZES", "3,5,10"), ",")[[1]])
impls <- strsplit(Sys.getenv("RHO_X_IMPLEMENTATIONS", "issue,old,new,plain"), ",")[[1]]
old_lib <- old_griddy_lib()
runs <- list()
if ("old" %in% impls) runs$old <- list(impl = "griddy", lib = old_lib, env = character())
# after old, which the others are compared with
if ("issue" %in% impls) {
  runs$issue <- list(impl = "griddy", env = character(),
                     lib = old_griddy_lib(Sys.getenv("GRIDDY_ISSUE_LIB", "/tmp/lib-griddy-e0ff0cf"),
                                          commit = "e0ff0cf"))
}
if ("new" %in% impls) {
  for (th in new_griddy_threads()) {
    label <- if (is.na(th)) "new" else paste0("new-", th, "threads")
    runs[[label]] <- list(impl = "griddy", lib = new_griddy_lib(),
                          env = if (is.na(th)) character() else paste0("GRIDDY_THREADS=", th))
  }
}
if ("plain" %in% impls) runs$plain <- list(impl = "plain", lib = old_lib, env = character())

dir <- tempfile("rho-x-grid-")
dir.create(dir)
start_note <- machine_note()
run_child("bench/rho-x-grid.R", c("--inputs", dir), lib = old_lib)
inputs <- readRDS(file.path(dir, "inputs.rds"))
build_s <- inputs$build_s
n_runs <- nrow(inputs$y)
rm(inputs)
rows <- list()
posteriors <- list()
for (k in sizes) {
  # what the child of `label` wrote at this size
  out <- function(label, suffix) file.path(dir, paste0(label, "-", k, suffix))
  for (label in names(runs)) {
    r <- runs[[label]]
    cat(sprintf("%s, %d values per coordinate ...\n", label, k))
    run_child("bench/rho-x-grid.R", c("--one", r$impl, label, k, dir), lib = r$lib, env = r$env)
    row <- data.table::fread(out(label, ".csv"))
    post <- data.table::fread(out(label, "-posterior.csv"))
    posteriors[[length(posteriors) + 1]] <- cbind(implementation = label,
                                                 rho_values_per_coordinate = k, post)
    if (label != "old" && "old" %in% names(runs)) {
      row[, C_max_rel_diff_vs_old := max_rel_diff_bin(out(label, "-C.bin"), out("old", "-C.bin"))]
      row[, draws_identical_to_old := identical(readRDS(out(label, "-draws.rds")),
                                                readRDS(out("old", "-draws.rds")))]
      row[, max_mean_z_vs_old := max_mean_z(as.data.frame(post), as.data.frame(
        data.table::fread(out("old", "-posterior.csv"))))]
    }
    if (label != "old") unlink(out(label, "-C.bin"))
    print(row[, .(implementation, grid_points, calibrate_s, precompute_s, sampling_s,
                  peak_extra_mb, cpu_per_elapsed, load_1min)])
    rows[[length(rows) + 1]] <- row
  }
  unlink(out("old", "-C.bin"))
}
unlink(dir, recursive = TRUE)
results <- data.table::rbindlist(rows, fill = TRUE)
results[, warnings := data.table::fifelse(is.na(warnings), "", as.character(warnings))]
results[, shared_machine := other_cores > 0.2]
if ("old" %in% names(runs)) {
  results[, speedup_vs_old := calibrate_s[implementation == "old"] / calibrate_s,
          by = grid_points]
}
if ("plain" %in% names(runs)) {
  results[, speedup_vs_plain := calibrate_s[implementation == "plain"] / calibrate_s,
          by = grid_points]
}
for (col in c("C_max_rel_diff_vs_old", "draws_identical_to_old", "max_mean_z_vs_old",
              "speedup_vs_old", "speedup_vs_plain")) {
  if (!col %in% names(results)) results[, (col) := NA]
}
results[, faster_than_thesis_40s := calibrate_s < thesis_seconds]
results[, under_goal_10s := calibrate_s < goal_seconds]
results[, library_build_s := build_s]
results[, machine := start_note]
results[, date := format(Sys.Date())]
dir.create("bench/results", showWarnings = FALSE, recursive = TRUE)
data.table::fwrite(results, file.path("bench/results", paste0(result_name, ".csv")))
data.table::fwrite(data.table::rbindlist(posteriors, fill = TRUE),
                   file.path("bench/results", paste0(result_name, "-posterior.csv")))

# The Markdown report: the issue's table, the new columns, the bar and the goal.
shown <- results[, .(
  implementation, `rho grid` = paste(rho_values_per_coordinate, "per coordinate"),
  `grid points` = format(grid_points, big.mark = ","),
  `calibrate() total (s)` = signif(calibrate_s, 3),
  `of which precompute (s)` = signif(precompute_s, 3),
  `sampling (s)` = signif(sampling_s, 3), `CPU (s)` = signif(cpu_s, 3), `C (MB)` = round(C_mb),
  `peak above start (MB)` = round(peak_extra_mb), `CPU / elapsed` = round(cpu_per_elapsed, 2),
  threads = threads_label(threads_option, griddy_threads, os_threads),
  `other cores` = round(other_cores, 2), `load (1 min)` = load_1min,
  `vs old` = signif(speedup_vs_old, 3), `vs plain` = signif(speedup_vs_plain, 3),
  `C max rel. diff vs old` = ifelse(is.na(C_max_rel_diff_vs_old), "-",
                                    formatC(C_max_rel_diff_vs_old, format = "g", digits = 2)),
  `draws = old` = draws_identical_to_old,
  `max |z| of means vs old` = signif(max_mean_z_vs_old, 2),
  `< 40 s (thesis)` = faster_than_thesis_40s, `< 10 s (goal)` = under_goal_10s)]
post <- data.table::rbindlist(posteriors, fill = TRUE)
post[, shown := ifelse(is.na(mcse), format(signif(mean, 5)),
                       paste0(signif(mean, 5), " ± ", signif(mcse, 2)))]
post_wide <- data.table::dcast(post, rho_values_per_coordinate + parameter ~ implementation,
                               value.var = "shown")
data.table::setcolorder(post_wide, c("rho_values_per_coordinate", "parameter",
                                     intersect(names(runs), names(post_wide))))
data.table::setnames(post_wide, "rho_values_per_coordinate", "rho values per coordinate")
md <- c(
  md_header(paste0("The rho_x-grid case of issue 15, side by side",
                   if (x_case == "random") ": x drawn at random"),
            "bench/rho-x-grid.R", start_note, results$load_1min, results$other_cores),
  "",
  paste0(format(n_runs, big.mark = ","), " runs x 54 data points (the piston library, ",
         round(n_runs^(1 / 3)), " values per coefficient; ",
         if (x_case == "random") "x = 3 coordinates drawn uniformly on [0, 1] per data point, seed 1" else
           "x = r, z, condition", "), one rho_x grid per coordinate, seq(0, 0.9, length.out = k), ",
         "every combination; `x_power = 1` (Appendix A's eq. 5); ", format(n_iter, big.mark = ","),
         " iterations (burn-in ", format(burn_in, big.mark = ","), "), collapsed update, seed 1. ",
         "Building the library (", round(build_s, 1), " s) is not timed."),
  "",
  md_table(shown),
  "",
  paste0("- Bar: the thesis's whole calibration, about 40 s (Table 4.5: ", thesis_seconds,
         " s at 54 data points). Goal: 1,000 grid points in under ", goal_seconds, " s."),
  "- `issue`: griddy at e0ff0cf, the commit issue 15 measured (0.1.0); `old`: griddy at c18971b (main before issue 15); `new`: the library in GRIDDY_NEW_LIB; `plain`: the thesis's Appendix A loop in plain R (C by `plain_quad_forms_x()`, then `thesis_plain_r()`; uniform prior over grid points, which here equals griddy's prior over distinct structures: every R_x of these grids differs).",
  "- CPU: CPU seconds of the process (all its threads) during the call (for the plain loop scaled as its time); CPU / elapsed: about 1 is one core busy throughout, below 1 means the process waited for a core (a shared machine), about 2 is both cores.",
  "- threads: option `griddy.threads` as set (\"default\" if unset) -> the threads `griddy_threads()` gives (- where the code has no such function: one), and the process's OS threads after the call.",
  "- C max rel. diff: largest elementwise |C - C_old| / C_old. max |z|: largest difference of posterior means (theta and rho_x) in Monte Carlo standard errors; a parameter whose draws sit on one value in both fits counts as 0 when the values agree. The issue's code reports no Monte Carlo standard error, so its |z| uses the old code's alone.",
  if (any(results$plain_iterations < n_iter)) paste0(
    "- The plain loop ran ",
    paste(unique(results[implementation == "plain", plain_iterations]), collapse = "/"),
    " iterations; its sampling time is scaled linearly to ", n_iter, " (PLAIN_MAX_ITER)."),
  "",
  "Posterior means ± Monte Carlo standard error (no ± where every kept draw sits on one value):",
  "",
  md_table(post_wide),
  "",
  if (any(nzchar(results$warnings))) paste0(
    "- Warnings from calibrate(): ",
    paste(unique(paste0(results$implementation, " at ", results$grid_points, ": ",
                        results$warnings)[nzchar(results$warnings)]), collapse = "; "), ".")
)
writeLines(md, file.path("bench/results", paste0(result_name, ".md")))
cat(md, sep = "\n")
