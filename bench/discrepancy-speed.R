# Issue 23, item 6: a discrepancy grid of about a hundred hyperparameter
# points on the thesis's 59,319-run, 54-point case (chapter 4's piston
# problem: 39 values per coefficient, 27 locations x 2 operating conditions,
# piston_field_data(54, discrepancy = TRUE, seed = 2023), as in
# bench/ess-per-second.R), against RobustCalibration with a discrepancy on
# the same field data.
#
#  * griddy: calibrate() over the 59,319-run library, 35,000 iterations
#    (burn-in 15,000), default collapsed update, with
#      - no discrepancy (discrepancy = NULL, rho fixed: the thesis's model),
#      - gp_discrepancy() (the default grid: ratio 0 and 11 positive ratios
#        x 3 length_x; this library has one output per x setting, so no
#        length_t axis: 1 + 11 x 3 = 34 discrepancy points),
#      - gp_discrepancy(length_x = 9 values from 0.05 to 2): 1 + 11 x 9 =
#        100 discrepancy points, "a hundred or so",
#    each timed as the median of DISC_REPEATS calls (default 3).
#  * RobustCalibration: koh_calibrate() (rcalibration() with a ppgasp emulator
#    of the 343-run library, 7 values per coefficient: RobustCalibration
#    needs a math model it can evaluate at any theta, and 59,319 runs are far
#    beyond a GP emulator's training size) with discrepancy_type "GaSP" and
#    "S-GaSP", and "no-discrepancy" for the reference; proposal tuned by 3
#    pilot runs of 1,000 iterations, then KOH_ITER (12,000) iterations,
#    burn-in KOH_BURN (2,000). Timed: the whole call (emulator, tuning,
#    sampling), once each.
# Every call is timed in elapsed and CPU seconds (all threads of this
# process; CPU above elapsed means griddy's threads ran in parallel), with
# the cores other processes kept busy meanwhile (from /proc/stat).
# Effective samples: coda::effectiveSize() of each coefficient's kept draws
# (and posterior::ess_bulk() beside it), the smallest over the coefficients
# whose draws move (a griddy coefficient whose kept draws all sit on one
# library value has none; n_constant counts them). Seconds per effective
# sample = seconds / that smallest ESS; `per_ess_vs_griddy` is a method's
# seconds per effective sample over griddy's with the same discrepancy
# ("none" against "none"; GaSP and S-GaSP against griddy's 101-point grid).
#
# Usage, from the package root (GRIDDY_LOAD_ALL=true: pkgload::load_all()):
#   GRIDDY_LOAD_ALL=true Rscript bench/discrepancy-speed.R
# Options (environment): KOH_ITER, KOH_BURN, DISC_REPEATS, DISC_PROFILE=true
# (also Rprof() one call with the 100-point grid and print where its time
# goes). Writes bench/results/discrepancy-speed.csv and .md. About 3-5
# minutes on a shared 2-core machine.
source("bench/helpers.R")
load_griddy()
stopifnot(requireNamespace("RobustCalibration", quietly = TRUE),
          requireNamespace("coda", quietly = TRUE))
start_note <- machine_note()
griddy_iter <- 35000L
griddy_burn <- 15000L
koh_iter <- as.integer(Sys.getenv("KOH_ITER", "12000"))
koh_burn <- as.integer(Sys.getenv("KOH_BURN", "2000"))
repeats <- as.integer(Sys.getenv("DISC_REPEATS", "3"))
seed <- 54

# DISC_INPUTS: an rds of list(lib39 = piston_case_inputs(39), lib7 =
# piston_case_inputs(7)) made earlier (building them takes 0.5-6 minutes)
cache <- Sys.getenv("DISC_INPUTS", "")
build_s <- system.time(inputs <- if (nzchar(cache) && file.exists(cache)) readRDS(cache) else
  list(lib39 = piston_case_inputs(39), lib7 = piston_case_inputs(7)))[["elapsed"]]
lib39 <- case_library(inputs$lib39)
lib7 <- case_library(inputs$lib7)
field <- case_field(inputs$lib39)
htc <- names(inputs$lib39$theta)

# Effective samples of each coefficient: coda's and posterior's; NA for one
# whose kept draws sit on one value.
ess_table <- function(draws) {
  rbindlist(lapply(htc, function(p) {
    v <- draws[[p]]
    moves <- any(v != v[1])
    data.table(parameter = p,
               ess_coda = if (moves) unname(coda::effectiveSize(v)) else NA_real_,
               ess_bulk = if (moves) posterior::ess_bulk(v) else NA_real_,
               mean = mean(v))
  }))
}
smallest <- function(v) if (all(is.na(v))) NA_real_ else min(v, na.rm = TRUE)

discrepancies <- list(
  none = NULL,
  default = gp_discrepancy(),
  hundred = gp_discrepancy(length_x = round(10^seq(-1.3, 0.3, length.out = 9), 3))
)
rows <- list()
params <- list()
for (d in names(discrepancies)) {
  disc <- discrepancies[[d]]
  n_points <- if (is.null(disc)) 1L else nrow(griddy:::discrepancy_points(disc, lib39))
  calls <- lapply(seq_len(repeats), function(i) measure_call(suppressWarnings(
    calibrate(lib39, field, n_iter = griddy_iter, burn_in = griddy_burn, seed = seed,
              discrepancy = disc, progress = FALSE))))
  elapsed <- vapply(calls, `[[`, 0, "elapsed_s")
  mid <- calls[[order(elapsed)[ceiling(repeats / 2)]]]
  fit <- mid$value
  th <- fit$library$theta[fit$draws$run, , drop = FALSE]
  ess <- ess_table(th)
  method <- if (is.null(disc)) "griddy (none)" else
    sprintf("griddy (gp_discrepancy, %d points)", n_points)
  ev <- if (!is.null(disc)) discrepancy_evidence(fit)
  rows[[method]] <- data.table(
    method = method, discrepancy = if (is.null(disc)) "none" else "GP grid",
    hyper_points = n_points, elapsed_s = mid$elapsed_s, cpu_s = mid$cpu_s,
    elapsed_all = paste(round(elapsed, 2), collapse = " "),
    precompute_s = fit$runtime[["precompute"]], sampling_s = fit$runtime[["sampling"]],
    iterations = griddy_iter, kept_draws = nrow(fit$draws),
    min_ess_coda = smallest(ess$ess_coda), min_ess_bulk = smallest(ess$ess_bulk),
    n_constant = sum(is.na(ess$ess_coda)),
    log_bf = if (!is.null(ev)) ev$log_bayes_factor else NA_real_,
    peak_extra_mb = mid$peak_extra_mb, other_cores = mid$other_cores)
  params[[method]] <- cbind(method = method, ess)
  cat(sprintf("%-40s %7.2f s elapsed, %7.2f s CPU\n", method, mid$elapsed_s, mid$cpu_s))
  if (identical(d, "hundred") && identical(Sys.getenv("DISC_PROFILE"), "true")) {
    prof <- tempfile(fileext = ".out")
    Rprof(prof, interval = 0.01)
    invisible(suppressWarnings(calibrate(lib39, field, n_iter = griddy_iter,
                                         burn_in = griddy_burn, seed = seed,
                                         discrepancy = disc, progress = FALSE)))
    Rprof(NULL)
    print(head(summaryRprof(prof)$by.total, 25))
  }
}

koh_types <- c(none = "no-discrepancy", GaSP = "GaSP", `S-GaSP` = "S-GaSP")
for (d in names(koh_types)) {
  m <- measure_call(suppressWarnings(koh_calibrate(lib7, field, discrepancy = d,
                                                   n_iter = koh_iter, burn_in = koh_burn,
                                                   seed = seed)))
  kf <- m$value
  ess <- ess_table(kf$draws)
  method <- sprintf("RobustCalibration (%s)", koh_types[[d]])
  rows[[method]] <- data.table(
    method = method, discrepancy = d, hyper_points = NA_integer_,
    elapsed_s = m$elapsed_s, cpu_s = m$cpu_s, elapsed_all = format(round(m$elapsed_s, 2)),
    precompute_s = kf$runtime[["emulator"]] + kf$runtime[["tuning"]],
    sampling_s = kf$runtime[["sampling"]], iterations = koh_iter, kept_draws = nrow(kf$draws),
    min_ess_coda = smallest(ess$ess_coda), min_ess_bulk = smallest(ess$ess_bulk),
    n_constant = sum(is.na(ess$ess_coda)), log_bf = NA_real_,
    peak_extra_mb = m$peak_extra_mb, other_cores = m$other_cores)
  params[[method]] <- cbind(method = method, ess)
  cat(sprintf("%-40s %7.2f s elapsed, %7.2f s CPU (acceptance %.2f)\n", method, m$elapsed_s,
              m$cpu_s, kf$acceptance[["theta"]]))
}

results <- rbindlist(rows)
parameters <- rbindlist(params)
results[, s_per_ess := elapsed_s / min_ess_coda]
results[, cpu_s_per_ess := cpu_s / min_ess_coda]
# each method against griddy with the same kind of discrepancy
reference <- function(d) {
  m <- if (d == "none") "griddy (none)" else grep("^griddy \\(gp", results$method, value = TRUE)
  results[method == m[length(m)]]
}
results[, per_ess_vs_griddy := vapply(seq_len(.N), function(i) {
  ref <- reference(if (discrepancy[i] == "none") "none" else "GP")
  s_per_ess[i] / ref$s_per_ess
}, 0)]
results[, cpu_per_ess_vs_griddy := vapply(seq_len(.N), function(i) {
  ref <- reference(if (discrepancy[i] == "none") "none" else "GP")
  cpu_s_per_ess[i] / ref$cpu_s_per_ess
}, 0)]
results[, `:=`(n_runs = nrow(inputs$lib39$y), n_points = length(inputs$lib39$field_y),
               threads = griddy_threads(), machine = start_note, date = format(Sys.Date()))]
dir.create("bench/results", showWarnings = FALSE, recursive = TRUE)
fwrite(results, "bench/results/discrepancy-speed.csv")
fwrite(parameters, "bench/results/discrepancy-speed-parameters.csv")

shown <- results[, .(method, `hyper-points` = fifelse(is.na(hyper_points), "-",
                                                      format(hyper_points)),
                     `elapsed (s)` = fmt3(elapsed_s), `CPU (s)` = fmt3(cpu_s),
                     `precompute (s)` = fmt3(precompute_s), `sampling (s)` = fmt3(sampling_s),
                     iterations, `min ESS (coda)` = round(min_ess_coda),
                     `min bulk ESS` = round(min_ess_bulk),
                     `coefficients on one value` = n_constant,
                     `s / ESS` = fmt3(s_per_ess),
                     `s / ESS over griddy's` = fmt3(per_ess_vs_griddy),
                     `CPU s / ESS over griddy's` = fmt3(cpu_per_ess_vs_griddy),
                     `log BF` = round(log_bf, 1), `other cores` = round(other_cores, 2))]
md <- c(
  md_header("A discrepancy on the 59,319-run, 54-point case: griddy against RobustCalibration",
            "bench/discrepancy-speed.R", start_note, load_1min(), results$other_cores),
  "",
  paste0("griddy: ", format(nrow(inputs$lib39$y), big.mark = ","), "-run library, ",
         format(griddy_iter, big.mark = ","), " iterations (burn-in ",
         format(griddy_burn, big.mark = ","), "), default update, ", griddy_threads(),
         " thread(s), median of ", repeats, " calls (all: `elapsed_all` in the csv). ",
         "RobustCalibration: koh_calibrate() on the 343-run library (ppgasp emulator), ",
         format(koh_iter, big.mark = ","), " iterations (burn-in ",
         format(koh_burn, big.mark = ","), ") after 3 x 1,000 tuning iterations; its ",
         "seconds include the emulator and the tuning ('precompute'). ESS: ",
         "coda::effectiveSize() of each coefficient's kept draws, the smallest over the ",
         "coefficients that move (bulk ESS, posterior::ess_bulk, beside it). 's / ESS over ",
         "griddy's': seconds per effective sample over griddy's with the same kind of ",
         "discrepancy (none against none; GaSP and S-GaSP against griddy's largest grid). ",
         "Building (or reading) the libraries (", round(build_s, 1), " s) is not timed."),
  "",
  md_table(shown)
)
writeLines(md, "bench/results/discrepancy-speed.md")
cat(md, sep = "\n")
