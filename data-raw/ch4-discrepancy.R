# Precomputes the section "Griddy Gibbs with a discrepancy, beside
# RobustCalibration with one" of vignette("chapter4") (issues 23 and 33): on
# the chapter-4 data (piston_field_data(n, discrepancy = TRUE, seed = 2023),
# n = 6, 15, 27, 54), per data size:
#  * griddy without a discrepancy: calibrate() over the 59,319-run library
#    (39 values per coefficient), rho_x = 0, as in data-raw/ch4.R;
#  * griddy with gp_discrepancy() (the default grid, orthogonal: theta is the
#    best-fitting value, the L2 projection) and with
#    gp_discrepancy(orthogonal = FALSE) (Kennedy and O'Hagan's theta, as
#    RobustCalibration reports it), each on the same library and then after
#    refine(fit, simulator) with piston_model() as the simulator (default
#    max_runs = 4000 and runs per round; the seed of the fit), so that theta
#    is no longer held to library values 315 W/m2K apart;
#  * RobustCalibration's rcalibration() with discrepancy_type "GaSP" and
#    "S-GaSP", through koh_calibrate() (a ppgasp emulator of the 343-run
#    library, 7 values per coefficient; 6 tuning runs of 1,000 iterations as
#    in data-raw/ch4.R, then 12,000 iterations, burn-in 2,000);
#  * and, to separate the emulator's part, RobustCalibration's GaSP with
#    piston_model() itself as its math model (the same call, with griddy's
#    koh_emulate() replaced by the simulator for that call only).
# griddy runs 35,000 iterations (burn-in 15,000). Per fit and coefficient:
# posterior mean and median, 95% interval, whether it holds the truth and the
# L2 projection (theta_l2 below); per fit: elapsed and CPU seconds of the call
# (griddy: calibrate() or refine(); KOH: the emulator, tuning and sampling),
# the smallest bulk ESS, the warnings it gave, and for griddy with a
# discrepancy its log Bayes factor and refine()'s runs and rounds.
# Also, to explain the differences that remain:
#  * `hyper`: the posterior of the discrepancy's variance ratio (discrepancy
#    variance over noise variance) and length scale of every fit with a
#    discrepancy (griddy: its grid margins; RobustCalibration: its draws of
#    the nugget eta, ratio = 1/eta, and inverse ranges beta, length =
#    1/(beta x column range), captured from rcalibration() by trace());
#  * `rc_prior`: RobustCalibration's default prior on the ratio (its jointly
#    robust prior on (beta, eta), a = 1/2 - p_x, b = 1), integrated here;
#  * `theta_l2`: the L2 projection, the theta whose piston_model() output is
#    closest in least squares to reality (the model at the truth plus the
#    drawn discrepancy) over each data set's settings;
#  * `emulator`: RobustCalibration's emulator error at the truth (RMS over
#    the outputs, against the noise sd).
# Fixed seeds (data 2023, each fit and refine() seed n). Writes
# inst/extdata/chapter4_discrepancy.rds (xz).
#
# Usage, from the package root with griddy and RobustCalibration installed
# (or GRIDDY_LOAD_ALL=true to use pkgload::load_all()):
#   GRIDDY_LOAD_ALL=true Rscript data-raw/ch4-discrepancy.R
# About 19 minutes on a shared 2-core machine (load 2-5), plus 1-5 to build the two
# libraries unless CH4_INPUTS names a cache (stored as settings$script_s).
script_start <- proc.time()[["elapsed"]]
source("bench/helpers.R")
load_griddy()
stopifnot(requireNamespace("RobustCalibration", quietly = TRUE))
start_note <- machine_note()

sizes <- c(6, 15, 27, 54)
data_seed <- 2023
griddy_iter <- 35000L
griddy_burn <- 15000L
koh_iter <- 12000L
koh_burn <- 2000L
koh_tune_rounds <- 6L
truth <- c(htc_undercrown = 1000, htc_gallery1 = 3000, htc_gallery2 = 2000)
noise_var <- 0.4                 # piston_field_data()'s default
discrepancies <- list(orthogonal = gp_discrepancy(),
                      ko = gp_discrepancy(orthogonal = FALSE))
labels <- c(orthogonal = "griddy, orthogonal", ko = "griddy, orthogonal = FALSE")

# Libraries once over all 54 outputs, cut to each data set's outputs (as in
# bench/koh-vs-griddy.R).
cut_library <- function(lib54, f) {
  key54 <- paste(lib54$x$condition, lib54$x$r, lib54$x$z)
  cond_id <- match(attr(f, "condition"), piston_conditions()$condition)
  x <- f$x
  key <- paste(if (length(cond_id) > 1L) x$condition else cond_id, x$r, x$z)
  cols <- match(key, key54)
  stopifnot(!anyNA(cols))
  sim_library(lib54$theta, lib54$y[, cols, drop = FALSE], x = x)
}
# CH4_INPUTS: an rds of list(lib39 = piston_case_inputs(39), lib7 =
# piston_case_inputs(7)) (bench/helpers.R; the same two libraries) made
# earlier, as building them takes 0.5-6 minutes
cache <- Sys.getenv("CH4_INPUTS", "")
if (nzchar(cache) && file.exists(cache)) {
  cached <- readRDS(cache)
  lib39_all <- case_library(cached$lib39)
  lib7_all <- case_library(cached$lib7)
} else {
  lib39_all <- piston_library(39, locations = 1:27, condition = c("full", "part"))
  lib7_all <- piston_library(7, locations = 1:27, condition = c("full", "part"))
}

# The simulator refine() calls: theta rows -> piston_model() at the data
# set's locations and conditions, which is the cut library's column order
# (checked below against the library's runs).
piston_simulator <- function(f) {
  locations <- attr(f, "locations")
  condition <- attr(f, "condition")
  function(theta) {
    unname(piston_model(as.matrix(theta[, names(truth)]), locations = locations,
                        condition = condition))
  }
}

# The L2 projection: the theta whose simulator output is closest to reality
# (the model at the truth plus the drawn discrepancy, no noise) over the
# data's settings; Nelder-Mead on theta / 1000 from the truth, then from its
# answer again.
theta_l2 <- function(f, simulator) {
  reality <- attr(f, "clean") + attr(f, "discrepancy")
  loss <- function(s) {
    sum((simulator(as.data.frame(as.list(stats::setNames(1000 * s, names(truth))))) -
           reality)^2)
  }
  start <- truth / 1000
  for (i in 1:2) start <- stats::optim(start, loss, control = list(reltol = 1e-12,
                                                                   maxit = 5000))$par
  stats::setNames(1000 * start, names(truth))
}

# Evaluates `expr`, muffling and recording its warnings (griddy's by class:
# the gap and resolution warnings are part of what is measured; others by
# their message) and dropping messages (refine()'s progress notes).
with_warnings <- function(expr) {
  classes <- character()
  value <- withCallingHandlers(suppressMessages(expr), warning = function(w) {
    classes <<- c(classes, if (inherits(w, "griddy_warning")) {
      sub("^griddy_warning_", "", class(w)[1])
    } else {
      paste0("'", conditionMessage(w), "'")
    })
    invokeRestart("muffleWarning")
  })
  list(value = value, warnings = paste(unique(classes), collapse = ", "))
}

# RobustCalibration's main run, captured to read its draws of the
# discrepancy's hyperparameters (koh_calibrate() keeps theta and sigma2):
# the last rcalibration() of a koh_calibrate() call is its main run.
rc_capture <- new.env()
suppressMessages(trace("rcalibration", where = asNamespace("RobustCalibration"), print = FALSE,
                       exit = quote(assign("last", returnValue(), envir = rc_capture))))

# One fit's rows: per coefficient its summary, and the call's cost.
fit_rows <- function(n, method, m, l2, warnings = "", refinement = NULL) {
  s <- as.data.frame(unclass(summary(m$value)))
  s <- s[s$parameter %in% names(truth), ]
  ev <- if (inherits(m$value, "griddy_fit") && !is.null(m$value$setup$discrepancy)) {
    discrepancy_evidence(m$value)
  }
  p <- s$parameter
  data.table(n_points = n, method = method, parameter = p, estimate = s$mean,
             median = s$median, lower = s$lower, upper = s$upper, truth = truth[p],
             covers = s$lower <= truth[p] & truth[p] <= s$upper, theta_l2 = l2[p],
             covers_l2 = s$lower <= l2[p] & l2[p] <= s$upper,
             ess_bulk = s$ess_bulk, elapsed_s = m$elapsed_s, cpu_s = m$cpu_s,
             other_cores = m$other_cores, warnings = warnings,
             log_bayes_factor = if (is.null(ev)) NA_real_ else ev$log_bayes_factor,
             prob_none = if (is.null(ev)) NA_real_ else ev$prob_none,
             runs_added = if (is.null(refinement)) NA_integer_ else refinement$runs_added,
             rounds = if (is.null(refinement)) NA_integer_ else refinement$rounds,
             reason = if (is.null(refinement)) NA_character_ else refinement$reason)
}

# The posterior of a griddy discrepancy's ratio and length scale (its exact
# grid margins; the length among ratio > 0).
griddy_hyper <- function(n, method, fit) {
  ev <- discrepancy_evidence(fit)
  rbind(data.table(n_points = n, method = method, quantity = "ratio", value = ev$ratio$ratio,
                   prob = ev$ratio$prob),
        data.table(n_points = n, method = method, quantity = "length_x",
                   value = ev$length_x$delta_length_x, prob = ev$length_x$prob))
}

# The same from RobustCalibration's draws after burn-in: the ratio
# sigma_delta^2 / sigma_0^2 = 1/eta (its covariance is sigma_0^2 (R / eta +
# I)), and each input's range 1/beta over that input's range in the data.
rc_hyper <- function(n, method, rc, p, inputs) {
  post <- as.matrix(rc@post_sample)
  px <- ncol(rc@input)
  log_beta <- post[, p + seq_len(px), drop = FALSE]
  log_eta <- post[, p + px + 1L]
  col_range <- apply(rc@input, 2, function(v) diff(range(v)))
  draws <- c(list(ratio = exp(-log_eta)),
             stats::setNames(lapply(seq_len(px), function(j) {
               1 / (exp(log_beta[, j]) * col_range[j])
             }), paste0("length_", inputs)))
  rbindlist(lapply(names(draws), function(q) {
    data.table(n_points = n, method = method, quantity = q,
               value = stats::quantile(draws[[q]], c(0.025, 0.5, 0.975), names = FALSE),
               prob = c(0.025, 0.5, 0.975))
  }))
}

# RobustCalibration's default prior on (beta, eta): density prop. to t^a
# exp(-b t), t = sum_l CL_l beta_l + eta, a = 1/2 - p_x, b = 1 (its
# Log_approx_ref_prior). With u = sum_l CL_l beta_l the margin of eta is
# prop. to int_0^inf u^(p_x - 1) (u + eta)^a exp(-(u + eta)) du, whatever CL.
# Returned: the prior probability that the ratio 1/eta is below 1 and below
# 0.1, and the prior's median ratio.
rc_ratio_prior <- function(px, a = 1 / 2 - px, b = 1) {
  dens <- Vectorize(function(eta) {
    stats::integrate(function(u) u^(px - 1) * (u + eta)^a * exp(-b * (u + eta)),
                     0, Inf)$value
  })
  total <- stats::integrate(dens, 0, Inf)$value
  cdf_eta <- function(e) stats::integrate(dens, 0, e)$value / total
  med_eta <- stats::uniroot(function(e) cdf_eta(e) - 0.5, c(1e-8, 50))$root
  data.table(p_x = px, a = a, b = b, prob_ratio_below_1 = 1 - cdf_eta(1),
             prob_ratio_below_0.1 = 1 - cdf_eta(10), median_ratio = 1 / med_eta)
}

# Evaluates `expr` (a koh_calibrate() call) with piston_model() in place of
# its emulator: koh_calibrate() hands RobustCalibration a math model that
# calls griddy's koh_emulate(), which is replaced here for this call only.
# The emulator is still fitted (its seconds count in the call's), not used.
with_simulator_as_emulator <- function(simulator, expr) {
  emulate <- griddy:::koh_emulate
  on.exit(utils::assignInNamespace("koh_emulate", emulate, "griddy"))
  utils::assignInNamespace("koh_emulate", function(emulator, th) {
    simulator(as.data.frame(stats::setNames(as.list(th[1, ]), names(truth))))
  }, "griddy")
  expr
}

rows <- list()
hyper <- list()
emulator <- list()
l2_rows <- list()
p_x <- integer()
for (n in sizes) {
  f <- piston_field_data(n, discrepancy = TRUE, seed = data_seed)
  lib39 <- cut_library(lib39_all, f)
  lib7 <- cut_library(lib7_all, f)
  simulator <- piston_simulator(f)
  check <- c(1L, 29660L, nrow(lib39$theta))
  stopifnot(max(abs(simulator(lib39$theta[check, ]) - lib39$y[check, ])) < 1e-9)
  l2 <- theta_l2(f, simulator)
  l2_rows[[length(l2_rows) + 1]] <- data.table(n_points = n, parameter = names(l2),
                                               theta_l2 = unname(l2))
  m <- measure_call(with_warnings(calibrate(lib39, f, n_iter = griddy_iter,
                                            burn_in = griddy_burn, seed = n,
                                            progress = FALSE)))
  w <- m$value$warnings
  m$value <- m$value$value
  rows[[length(rows) + 1]] <- fit_rows(n, "griddy, no discrepancy", m, l2, w)
  for (d in names(discrepancies)) {
    m <- measure_call(with_warnings(calibrate(lib39, f, n_iter = griddy_iter,
                                              burn_in = griddy_burn, seed = n,
                                              discrepancy = discrepancies[[d]],
                                              progress = FALSE)))
    w <- m$value$warnings
    fit <- m$value <- m$value$value
    rows[[length(rows) + 1]] <- fit_rows(n, labels[[d]], m, l2, w)
    hyper[[length(hyper) + 1]] <- griddy_hyper(n, labels[[d]], fit)
    m <- measure_call(with_warnings(refine(fit, simulator, seed = n, progress = FALSE)))
    w <- m$value$warnings
    m$value <- m$value$value
    label <- paste0(labels[[d]], ", refined")
    rows[[length(rows) + 1]] <- fit_rows(n, label, m, l2, w, m$value$refinement)
    hyper[[length(hyper) + 1]] <- griddy_hyper(n, label, m$value)
  }
  for (d in c("GaSP", "S-GaSP")) {
    m <- measure_call(with_warnings(koh_calibrate(
      lib7, f, discrepancy = d, n_iter = koh_iter, burn_in = koh_burn,
      tune_rounds = koh_tune_rounds, seed = n)))
    w <- m$value$warnings
    m$value <- m$value$value
    label <- paste0("RobustCalibration, ", d)
    rows[[length(rows) + 1]] <- fit_rows(n, label, m, l2, w)
    hyper[[length(hyper) + 1]] <- rc_hyper(n, label, rc_capture$last, length(truth),
                                             colnames(m$value$design))
    p_x[as.character(n)] <- ncol(rc_capture$last@input)
  }
  # the emulator RobustCalibration sampled on, against the simulator, at the
  # truth and at the L2 projection
  at <- rbind(truth, l2)
  err <- griddy:::koh_emulate(m$value$emulator, at) - simulator(as.data.frame(at))
  # RobustCalibration's GaSP with the simulator itself as its math model
  m <- measure_call(with_warnings(with_simulator_as_emulator(simulator, koh_calibrate(
    lib7, f, discrepancy = "GaSP", n_iter = koh_iter, burn_in = koh_burn,
    tune_rounds = koh_tune_rounds, seed = n))))
  w <- m$value$warnings
  m$value <- m$value$value
  label <- "RobustCalibration, GaSP, on the simulator"
  rows[[length(rows) + 1]] <- fit_rows(n, label, m, l2, w)
  hyper[[length(hyper) + 1]] <- rc_hyper(n, label, rc_capture$last, length(truth),
                                         colnames(m$value$design))
  emulator[[length(emulator) + 1]] <- data.table(
    n_points = n, at = c("truth", "theta_l2"), rms_error = sqrt(rowMeans(err^2)),
    max_error = apply(abs(err), 1, max), noise_sd = sqrt(noise_var))
  cat(sprintf("n = %2d done (%.0f s so far)\n", n, proc.time()[["elapsed"]] - script_start))
}
untrace("rcalibration", where = asNamespace("RobustCalibration"))
results <- rbindlist(rows)
print(results[, .(n_points, method, parameter, estimate = round(estimate, 1),
                  lower = round(lower, 1), upper = round(upper, 1), covers, covers_l2,
                  elapsed_s = round(elapsed_s, 2), log_bf = round(log_bayes_factor, 1),
                  runs_added, warnings)])

chapter4_discrepancy <- list(
  results = results,
  hyper = rbindlist(hyper),
  theta_l2 = rbindlist(l2_rows),
  emulator = rbindlist(emulator),
  rc_prior = rbindlist(lapply(sort(unique(p_x)), rc_ratio_prior)),
  rc_p_x = p_x,
  settings = list(data_seed = data_seed, griddy_iter = griddy_iter, griddy_burn = griddy_burn,
                  koh_iter = koh_iter, koh_burn = koh_burn, koh_tune_rounds = koh_tune_rounds,
                  discrepancy = unclass(discrepancies$orthogonal)[
                    c("ratio", "length_x", "length_t", "prior_none", "orthogonal")],
                  refine_max_runs = griddy_control()$max_runs,
                  rc_defaults = vapply(formals(RobustCalibration::rcalibration)[
                    c("a", "b", "kernel_type", "lambda_z")], deparse1, ""),
                  n_runs = nrow(lib39_all$theta), n_runs_emulator = nrow(lib7_all$theta),
                  noise_var = noise_var,
                  threads = griddy_threads(),
                  machine = paste0(start_note, "; at end: load average ",
                                   sub(".*load average ", "", machine_note())),
                  script_s = proc.time()[["elapsed"]] - script_start,
                  versions = c(griddy = format(utils::packageVersion("griddy")),
                               RobustCalibration = format(utils::packageVersion("RobustCalibration")),
                               R = R.version.string),
                  date = format(Sys.time(), "%Y-%m-%d %H:%M"))
)
saveRDS(chapter4_discrepancy, "inst/extdata/chapter4_discrepancy.rds", compress = "xz")
cat("inst/extdata/chapter4_discrepancy.rds:",
    file.size("inst/extdata/chapter4_discrepancy.rds"), "bytes\n")
