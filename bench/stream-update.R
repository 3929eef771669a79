# Issue 25: the time per measurement of a streaming calibration
# (griddy_stream() + update()) against a fresh calibrate() and a fresh
# posterior_exact() per measurement, at 10^4, 10^5 and 10^6 runs; and the
# checks the issue names: after the last measurement the stream's posterior
# and log evidence against posterior_exact() on all the data, and two
# candidate libraries ranked as the batch evidence ranks them.
#
# Library: STREAM_RUNS random runs of a two-parameter smooth response at
# 120 output coordinates (one x setting), 8 bytes x 120 per run (960 MB at
# 10^6). Field: 120 values of one run's response plus noise. Models:
# independent noise (rho_t = 0, one grid point) and an AR(1) grid over t
# (rho_t = 0, 0.5, 0.9: three grid points). 120 measurements arrive one at
# a time through update(stream, y =, t =); each update is timed as the
# whole R call (Sys.time() around it), and so is update() followed by
# logLik() (the evidence, one more pass, what stream_models() needs after
# every measurement).
#
# One memory pass: griddy's memory_pass_cpp() (a plain C++ read loop) over
# what an update must touch: the N x G forms C (read and written) and one
# output column (read), timed as a read of N x (G + 1) doubles.
#
# calibrate() (default 35,000 iterations, one chain) and posterior_exact()
# are timed once per size on all 120 measurements (what a fresh call per
# measurement costs at the end of the stream); at 10^6 runs calibrate()
# takes about 10 s.
#
# Paths (issue 36, item 3; STREAM_PART "paths" or "all"): the time per
# measurement by the path it takes in, on a library of 4 x settings x 30
# output coordinates, against the user's own running sum of squares over
# the runs in the same process (`ss <- ss + (y_lib[, j] - y)^2`, what one
# independent-noise form costs in R):
# * value: update(s, y = value, x = its setting (a one-row data.frame), t =);
# * field: update(s, y = field_data(one row: x, t, y));
# * batch: update(s, y = field_data(all 120)), per measurement;
# for independent noise (one grid point, the running sum's own model) and
# the AR(1) grid (three), measurements setting by setting in t order; and
# the same with 20% of the cells never measured (a stream's missing cells).
#
# Usage, from the package root, with griddy installed (R CMD INSTALL .):
#   Rscript bench/stream-update.R
# Options (environment): STREAM_RUNS (default "1e4,1e5,1e6"), STREAM_PART
# ("all", default; "paths": the paths table only, "update": the first table
# only), STREAM_OUT (default "stream-update-paths": the paths table's file
# name), GRIDDY_NEW_LIB (a library holding the griddy to test). Writes
# bench/results/stream-update.csv and .md, and the paths table's .csv and
# .md. About 2-3 minutes and 3 GB here.
source("bench/helpers.R")
if (nzchar(new_griddy_lib())) .libPaths(c(new_griddy_lib(), .libPaths()))
suppressPackageStartupMessages(library(griddy))
read_loop <- read_loop_fn()
sizes <- as.numeric(strsplit(Sys.getenv("STREAM_RUNS", "1e4,1e5,1e6"), ",")[[1]])
n_t <- 120
tt <- seq(0, 1, length.out = n_t)
response <- function(a, b) outer(a, 1 + tt) + outer(b, sin(6 * tt))
rho_models <- list(independent = 0, ar1 = c(0, 0.5, 0.9))
load_before <- load_1min()

elapsed_ms <- function(expr) {
  t0 <- Sys.time()
  force(expr)
  1000 * as.numeric(difftime(Sys.time(), t0, units = "secs"))
}

part <- Sys.getenv("STREAM_PART", "all")
rows <- list()
for (N in if (part %in% c("all", "update")) sizes else numeric()) {
  set.seed(1)
  theta <- data.frame(a = runif(N), b = runif(N))
  lib <- sim_library(theta, response(theta$a, theta$b), t = tt)
  # a rival library: the same runs without the sine term's curvature
  rival <- sim_library(theta, outer(theta$a, 1 + tt) + outer(theta$b, 6 * tt * (1 - tt)), t = tt)
  y <- as.vector(response(0.37, 0.61)) + rnorm(n_t, sd = 0.05)
  field <- field_data(y, t = tt)
  for (model in names(rho_models)) {
    rho_t <- rho_models[[model]]
    G <- length(rho_t)
    s <- griddy_stream(lib, rho_t = rho_t)
    update_ms <- vapply(seq_len(n_t), function(j) elapsed_ms(update(s, y = y[j], t = tt[j])),
                        numeric(1))
    s2 <- griddy_stream(lib, rho_t = rho_t)
    with_evidence_ms <- vapply(seq_len(n_t), function(j) {
      elapsed_ms({
        update(s2, y = y[j], t = tt[j])
        logLik(s2)
      })
    }, numeric(1))
    block <- matrix(1, N, G + 1L)
    pass_ms <- median(replicate(9, elapsed_ms(read_loop(block))))
    rm(block)
    exact_ms <- elapsed_ms(batch <- suppressWarnings(posterior_exact(lib, field, rho_t = rho_t)))
    calibrate_ms <- elapsed_ms(suppressWarnings(calibrate(lib, field, rho_t = rho_t, seed = 1)))
    streamed <- posterior_exact(s)
    # two candidates: the stream's evidences against the batch ones
    r <- update(griddy_stream(rival, rho_t = rho_t), y = field)
    batch_rival <- suppressWarnings(posterior_exact(rival, field, rho_t = rho_t, joint = FALSE))
    rows[[length(rows) + 1L]] <- data.frame(
      runs = N, model = model, grid_points = G, measurements = n_t,
      update_median_ms = median(update_ms), update_p90_ms = unname(quantile(update_ms, 0.9)),
      update_logLik_median_ms = median(with_evidence_ms),
      one_pass_ms = pass_ms, update_over_pass = median(update_ms) / pass_ms,
      posterior_exact_ms = exact_ms, calibrate_ms = calibrate_ms,
      max_run_prob_diff = max(abs(streamed$run - batch$run)),
      log_evidence_diff = as.numeric(logLik(s)) - batch$log_evidence,
      rival_log_evidence_diff = as.numeric(logLik(r)) - batch_rival$log_evidence,
      ranking_agrees = (as.numeric(logLik(s)) > as.numeric(logLik(r))) ==
        (batch$log_evidence > batch_rival$log_evidence),
      machine = machine_note())
    print(rows[[length(rows)]][, 1:15])
    rm(s, s2, r, streamed, batch)
    gc()
  }
  rm(lib, rival)
  gc()
}
if (part %in% c("all", "update")) {
out <- do.call(rbind, rows)
dir.create("bench/results", showWarnings = FALSE)
write.csv(out, "bench/results/stream-update.csv", row.names = FALSE)
fmt <- function(v, d = 3) format(signif(v, d), scientific = FALSE, trim = TRUE)
md <- c("# Streaming calibration: time per measurement (issue 25)", "",
        paste0("`Rscript bench/stream-update.R`; ", machine_note(), " (1-min load before: ",
               format(load_before), ")."), "",
        "| runs | model | G | update (median ms) | p90 | update + logLik | one pass (ms) | update / pass | posterior_exact (ms) | calibrate (ms) | max run prob. diff | log evidence diff | ranking as batch |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
        sprintf("| %s | %s | %d | %s | %s | %s | %s | %s | %s | %s | %.1e | %.1e | %s |",
                format(out$runs, big.mark = ",", scientific = FALSE), out$model, out$grid_points,
                fmt(out$update_median_ms), fmt(out$update_p90_ms),
                fmt(out$update_logLik_median_ms), fmt(out$one_pass_ms),
                fmt(out$update_over_pass, 2), fmt(out$posterior_exact_ms),
                fmt(out$calibrate_ms), out$max_run_prob_diff, abs(out$log_evidence_diff),
                out$ranking_agrees))
writeLines(md, "bench/results/stream-update.md")
writeLines(md)
}

# ---- the paths a measurement takes in ------------------------------------------
# this process's CPU time (s): a loaded machine deschedules a process for
# milliseconds at a time, which a median of elapsed times does not always hide
cpu_s <- function() sum(proc.time()[c("user.self", "sys.self")])
path_rows <- list()
for (N in if (part %in% c("all", "paths")) sizes else numeric()) {
  n_set <- 4
  n_tp <- 30
  case <- settings_times_case(N, n_set, n_tp, seed = 3)
  tp <- case$t
  xp <- case$x
  resp_p <- case$response
  y_lib <- case$y
  lib <- case$lib
  long <- data.frame(x = rep(xp$x, each = n_tp), t = rep(tp, n_set))
  long$y <- as.vector(resp_p(0.4, 0.6)) + rnorm(nrow(long), sd = 0.05)
  cols <- seq_len(nrow(long))
  for (missing in c(0, 0.2)) {
    set.seed(4)
    keep <- if (missing > 0) sort(sample(cols, round((1 - missing) * length(cols)))) else cols
    x_rows <- lapply(keep, function(m) xp[(m - 1L) %/% n_tp + 1L, , drop = FALSE])
    one_fields <- lapply(keep, function(m) field_data(long[m, ]))
    batch_field <- field_data(long[keep, ])
    # the user's running sum of squares, one measurement at a time
    ss <- numeric(N)
    cpu0 <- cpu_s()
    ss_ms <- vapply(keep, function(j) elapsed_ms(ss <<- ss + (y_lib[, j] - long$y[j])^2),
                    numeric(1))
    ss_cpu <- 1000 * (cpu_s() - cpu0) / length(keep)
    for (model in names(rho_models)) {
      rho_t <- rho_models[[model]]
      s_value <- griddy_stream(lib, rho_t = rho_t)
      cpu0 <- cpu_s()
      value_ms <- vapply(seq_along(keep), function(k) {
        elapsed_ms(update(s_value, y = long$y[keep[k]], x = x_rows[[k]], t = long$t[keep[k]]))
      }, numeric(1))
      value_cpu <- 1000 * (cpu_s() - cpu0) / length(keep)
      s_field <- griddy_stream(lib, rho_t = rho_t)
      cpu0 <- cpu_s()
      field_ms <- vapply(seq_along(keep), function(k) elapsed_ms(update(s_field, y = one_fields[[k]])),
                         numeric(1))
      field_cpu <- 1000 * (cpu_s() - cpu0) / length(keep)
      s_batch <- griddy_stream(lib, rho_t = rho_t)
      batch_ms <- elapsed_ms(update(s_batch, y = batch_field)) / length(keep)
      batch <- suppressWarnings(posterior_exact(lib, batch_field, rho_t = rho_t, joint = FALSE))
      diff_prob <- max(vapply(list(s_value, s_field, s_batch), function(s) {
        max(abs(posterior_exact(s, joint = FALSE)$run - batch$run))
      }, numeric(1)))
      path_rows[[length(path_rows) + 1L]] <- data.frame(
        runs = N, model = model, grid_points = length(rho_t), missing = missing,
        measurements = length(keep), running_ss_ms = median(ss_ms),
        value_ms = median(value_ms), field_ms = median(field_ms), batch_ms = batch_ms,
        value_over_ss = median(value_ms) / median(ss_ms),
        field_over_ss = median(field_ms) / median(ss_ms),
        running_ss_cpu_ms = ss_cpu, value_cpu_ms = value_cpu, field_cpu_ms = field_cpu,
        value_cpu_over_ss = value_cpu / ss_cpu, field_cpu_over_ss = field_cpu / ss_cpu,
        max_run_prob_diff = diff_prob, machine = machine_note())
      print(path_rows[[length(path_rows)]][, 1:12])
    }
  }
  rm(lib, y_lib)
  gc()
}
if (part %in% c("all", "paths")) {
  paths <- do.call(rbind, path_rows)
  out_name <- Sys.getenv("STREAM_OUT", "stream-update-paths")
  dir.create("bench/results", showWarnings = FALSE)
  write.csv(paths, file.path("bench/results", paste0(out_name, ".csv")), row.names = FALSE)
  fmt <- function(v, d = 3) format(signif(v, d), scientific = FALSE, trim = TRUE)
  md <- c(paste0("# A stream update by the path a measurement takes in (issue 36): ", out_name),
          "", paste0("`STREAM_PART=paths Rscript bench/stream-update.R`; ", machine_note(),
                     " (1-min load before: ", format(load_before), "). Medians of the ",
                     "elapsed time per measurement (ms), and the process's CPU time per ",
                     "measurement (mean, ms), one process; `/ ss`: over the running sum ",
                     "of squares in R."), "",
          "| runs | model | G | missing | running ss | value + x + t | / ss | one-row field | / ss | CPU: ss | CPU: value | / ss | CPU: field | / ss | batch field (per meas.) | max run prob. diff vs batch |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
          sprintf("| %s | %s | %d | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %.1e |",
                  format(paths$runs, big.mark = ",", scientific = FALSE), paths$model,
                  paths$grid_points, fmt(paths$missing, 2), fmt(paths$running_ss_ms),
                  fmt(paths$value_ms), fmt(paths$value_over_ss, 2), fmt(paths$field_ms),
                  fmt(paths$field_over_ss, 2), fmt(paths$running_ss_cpu_ms),
                  fmt(paths$value_cpu_ms), fmt(paths$value_cpu_over_ss, 2),
                  fmt(paths$field_cpu_ms), fmt(paths$field_cpu_over_ss, 2),
                  fmt(paths$batch_ms), paths$max_run_prob_diff))
  writeLines(md, file.path("bench/results", paste0(out_name, ".md")))
  writeLines(md)
}
