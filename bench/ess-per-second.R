# Effective samples per second: griddy against the traditional (KOH)
# calibration of RobustCalibration on the thesis's chapter 4 problem, 54 data
# points (27 locations x 2 conditions; piston_field_data(54, discrepancy =
# TRUE, seed = 2023), as in bench/koh-vs-griddy.R and data-raw/ch4.R).
#  * griddy: calibrate() over the 59,319-run library (39 values per
#    coefficient), rho fixed, 35,000 iterations (burn-in 15,000), with the
#    default collapsed update and with update = "thesis" (Appendix A's
#    sampler). A call is timed as the median of 5 identical calls.
#  * KOH: koh_calibrate() (RobustCalibration::rcalibration() with a ppgasp
#    emulator of the 343-run library, 7 values per coefficient) with
#    discrepancy "none" (the thesis's baseline: no discrepancy in the model)
#    and "GaSP"; proposal tuned by 3 pilot runs of 1,000 iterations, then
#    KOH_ITER iterations (default 12,000, burn-in KOH_BURN = 2,000, as in
#    koh-vs-griddy.R). Timed: the whole call (emulator, tuning, sampling).
# ESS: posterior's rank-normalised bulk ESS (posterior::ess_bulk) of each
# coefficient's kept draws (griddy: its summary()'s ess_bulk; KOH:
# posterior::ess_bulk on the draws); the smallest over the coefficients whose
# draws move (n_constant counts those whose kept draws all sit on one library
# value, which have no ESS). ESS per second = that smallest ESS / seconds.
#
# Side by side in one run, each in its own R process: griddy old (c18971b,
# GRIDDY_OLD_LIB, installed on first use), griddy new (GRIDDY_NEW_LIB,
# default the installed griddy) and KOH (with the koh_calibrate() of
# GRIDDY_NEW_LIB if set, else of the old library; needs RobustCalibration). Building the libraries is not
# timed.
#
# Usage, from the package root:
#   GRIDDY_NEW_LIB=/tmp/lib-new Rscript bench/ess-per-second.R
# Options (environment): ESS_IMPLEMENTATIONS (default "old,new,koh"),
# KOH_ITER, KOH_BURN, ESS_PER_DIM (values per coefficient of griddy's library,
# default 39; smaller for a smoke test). Writes bench/results/ess-per-second.csv (one row per
# method) and ess-per-second-parameters.csv (ESS per coefficient), and
# ess-per-second.md. About 3 minutes here.
source("bench/helpers.R")
args <- commandArgs(TRUE)
griddy_iter <- 35000L
griddy_burn <- 15000L
koh_iter <- as.integer(Sys.getenv("KOH_ITER", "12000"))
koh_burn <- as.integer(Sys.getenv("KOH_BURN", "2000"))
seed <- 54

# The parameters' ESS of a summary-like table (parameter, ess_bulk) or of
# draws, and the row of a method: smallest ESS over the coefficients that
# move, per second.
ess_row <- function(method, ess, seconds, sampling_s, iterations, kept) {
  moving <- ess[!is.na(ess)]
  data.frame(method = method, seconds = seconds, sampling_s = sampling_s,
             iterations = iterations, kept_draws = kept,
             min_ess = if (length(moving)) min(moving) else NA_real_,
             n_constant = sum(is.na(ess)),
             ess_per_s = if (length(moving)) min(moving) / seconds else NA_real_,
             ess_per_sampling_s = if (length(moving)) min(moving) / sampling_s else NA_real_)
}

if (length(args) == 2 && args[1] == "--inputs") {
  suppressPackageStartupMessages(library(griddy))
  per_dim <- as.integer(Sys.getenv("ESS_PER_DIM", 39))  # smaller for a smoke test
  saveRDS(list(lib39 = piston_case_inputs(per_dim), lib7 = piston_case_inputs(7)),
          file.path(args[2], "inputs.rds"), compress = FALSE)
  quit(save = "no")
}

# Child: one implementation; writes <label>.csv and <label>-parameters.csv.
if (length(args) == 3 && args[1] == "--one") {
  label <- args[2]
  dir <- args[3]
  load_before <- load_1min()
  suppressPackageStartupMessages(library(griddy))
  info <- griddy_child_setup()
  inputs <- readRDS(file.path(dir, "inputs.rds"))
  field <- case_field(inputs$lib39)
  rows <- list()
  params <- list()
  if (label == "koh") {
    stopifnot(requireNamespace("RobustCalibration", quietly = TRUE))
    lib7 <- case_library(inputs$lib7)
    for (d in c("none", "GaSP")) {
      m <- measure_call(koh_calibrate(lib7, field, discrepancy = d, n_iter = koh_iter,
                                      burn_in = koh_burn, seed = seed))
      kf <- m$value
      ess <- vapply(kf$parameters, function(p) {
        v <- kf$draws[[p]]
        if (all(v == v[1])) NA_real_ else posterior::ess_bulk(v)
      }, 0)
      method <- paste0("KOH (", d, ")")
      rows[[method]] <- cbind(ess_row(method, ess, m$elapsed_s,
                                      kf$runtime[["sampling"]], koh_iter, nrow(kf$draws)),
                              acceptance_theta = kf$acceptance[["theta"]],
                              cpu_per_elapsed = m$cpu_s / m$elapsed_s,
                              other_cores = m$other_cores)
      params[[method]] <- data.frame(method = method, parameter = kf$parameters, ess_bulk = ess,
                                     mean = colMeans(kf$draws[kf$parameters]))
    }
  } else {
    lib39 <- case_library(inputs$lib39)
    for (u in c("collapsed", "thesis")) {
      others <- other_work_start()
      calls <- lapply(1:5, function(i) measure_call(suppressWarnings(
        calibrate(lib39, field, n_iter = griddy_iter, burn_in = griddy_burn, update = u,
                  seed = seed, progress = FALSE))))
      secs <- vapply(calls, `[[`, 0, "elapsed_s")
      fit <- calls[[5]]$value
      s <- as.data.frame(unclass(summary(fit)))
      s <- s[s$parameter %in% names(inputs$lib39$theta), ]
      method <- paste0("griddy ", label, " (", u, ")")
      rows[[method]] <- cbind(ess_row(method, s$ess_bulk, median(secs),
                                      fit$runtime[["sampling"]], griddy_iter, nrow(fit$draws)),
                              acceptance_theta = NA_real_,
                              cpu_per_elapsed = calls[[5]]$cpu_s / calls[[5]]$elapsed_s,
                              other_cores = other_cores_since(others))  # over the 5 calls
      params[[method]] <- data.frame(method = method, parameter = s$parameter,
                                     ess_bulk = s$ess_bulk, mean = s$mean)
    }
  }
  data.table::fwrite(cbind(do.call(rbind, rows), info, load_1min = load_before),
                     file.path(dir, paste0(label, ".csv")))
  data.table::fwrite(do.call(rbind, params), file.path(dir, paste0(label, "-parameters.csv")))
  quit(save = "no")
}

impls <- strsplit(Sys.getenv("ESS_IMPLEMENTATIONS", "old,new,koh"), ",")[[1]]
# KOH runs with the new library's koh_calibrate(), or the old one's if none is given
libs <- c(old = old_griddy_lib(), new = new_griddy_lib(),
          koh = if (nzchar(new_griddy_lib())) new_griddy_lib() else old_griddy_lib())[impls]
dir <- tempfile("ess-per-second-")
dir.create(dir)
start_note <- machine_note()
run_child("bench/ess-per-second.R", c("--inputs", dir),
          lib = if ("old" %in% impls) libs[["old"]] else new_griddy_lib())
n_runs <- nrow(readRDS(file.path(dir, "inputs.rds"))$lib39$y)
for (label in impls) {
  cat(label, "...\n")
  run_child("bench/ess-per-second.R", c("--one", label, dir), lib = libs[[label]])
}
results <- data.table::rbindlist(lapply(impls, function(l) {
  data.table::fread(file.path(dir, paste0(l, ".csv")))
}), fill = TRUE)
parameters <- data.table::rbindlist(lapply(impls, function(l) {
  data.table::fread(file.path(dir, paste0(l, "-parameters.csv")))
}))
unlink(dir, recursive = TRUE)
results[, n_points := 54]
results[, shared_machine := other_cores > 0.2]
results[, machine := start_note]
results[, date := format(Sys.Date())]
reference <- results[method == "griddy new (collapsed)", ess_per_s]
if (length(reference) == 0) reference <- results[method == "griddy old (collapsed)", ess_per_s]
results[, ess_per_s_vs_griddy := if (length(reference)) signif(reference / ess_per_s, 3) else NA_real_]
dir.create("bench/results", showWarnings = FALSE, recursive = TRUE)
data.table::fwrite(results, "bench/results/ess-per-second.csv")
data.table::fwrite(parameters, "bench/results/ess-per-second-parameters.csv")

shown <- results[, .(method, `seconds` = signif(seconds, 3), `sampling (s)` = signif(sampling_s, 3),
                     iterations, `kept draws` = kept_draws, `min bulk ESS` = round(min_ess),
                     `coefficients on one value` = n_constant,
                     `ESS / s` = fmt3(ess_per_s),
                     `ESS / sampling s` = fmt3(ess_per_sampling_s),
                     `griddy's ESS/s over this` = fmt3(ess_per_s_vs_griddy),
                     `CPU / elapsed` = round(cpu_per_elapsed, 2), `other cores` = round(other_cores, 2), `load (1 min)` = load_1min)]
ess_wide <- data.table::dcast(parameters, parameter ~ method, value.var = "ess_bulk",
                              fun.aggregate = function(v) round(v[1]))
md <- c(
  md_header("Effective samples per second: griddy against RobustCalibration (chapter 4, 54 points)",
            "bench/ess-per-second.R", start_note, results$load_1min, results$other_cores),
  "",
  paste0("griddy: ", format(n_runs, big.mark = ","), "-run library, rho fixed, ",
         format(griddy_iter, big.mark = ","),
         " iterations (burn-in ", format(griddy_burn, big.mark = ","), "), median of 5 calls. ",
         "KOH: koh_calibrate() on the 343-run library, ", format(koh_iter, big.mark = ","),
         " iterations (burn-in ", format(koh_burn, big.mark = ","), ") after 3 x 1,000 tuning ",
         "iterations; seconds include the emulator and tuning. ESS: rank-normalised bulk ",
         "ESS (posterior::ess_bulk), the smallest over the coefficients whose draws move; ",
         "a coefficient whose kept draws all sit on one library value has none and is counted ",
         "in 'coefficients on one value'."),
  "",
  md_table(shown),
  "",
  "Bulk ESS per coefficient (NA: the kept draws sit on one value):",
  "",
  md_table(ess_wide)
)
writeLines(md, "bench/results/ess-per-second.md")
cat(md, sep = "\n")
