# Validation study of diagnose_gap(): field data whose effect is withheld from
# the calibrated model. Tyre: Fiala library, data from the PAC2002-style model
# with one effect on. Piston: base library, data with a graded gallery HTC or
# a temperature-dependent conductivity. Seeded trials; results go to
# inst/extdata/gap_validation_trials.csv.gz and gap_validation_examples.rds.
#
# Run from the package root:  Rscript data-raw/gap-validation.R  (single core,
# about 15-20 minutes before diagnose_gap() compared models at matched
# resolution; longer now). GAP_TRIALS_TYRE / GAP_TRIALS_PISTON set the trials
# per scenario (default 25 and 40). For a subset: GAP_SCENARIOS, a
# comma-separated list of scenario ids' first words (e.g. "T0b,P0b"), with
# the trials written to GAP_OUT (a .csv.gz file) instead of inst/extdata;
# GAP_MAX_RUNS is diagnose_gap()'s max_runs (0: the libraries as they are).

pkgload::load_all(".", quiet = TRUE)
library(data.table)

n_trials_tyre <- as.integer(Sys.getenv("GAP_TRIALS_TYRE", "25"))
n_trials_piston <- as.integer(Sys.getenv("GAP_TRIALS_PISTON", "40"))
started <- proc.time()[["elapsed"]]
only <- strsplit(Sys.getenv("GAP_SCENARIOS", ""), ",")[[1]]
subset_out <- Sys.getenv("GAP_OUT", "")
max_runs <- as.integer(Sys.getenv("GAP_MAX_RUNS", "2000"))
wanted <- function(sc) length(only) == 0L || sub(" .*", "", sc$id) %in% only

# ---- tyre ---------------------------------------------------------------------
rig <- tyre_rig(n_samples = 100)                    # first 100 ms: cleat and wheel hop
heights <- tyre_cleat_heights()
base_theta <- expand.grid(k = seq(150, 300, by = 5), c = seq(0.3, 1.3, by = 0.1))
lag1 <- c(0, 0.25, 0.5, 0.75)                       # AR(1) lag-one correlations fitted
rho_t <- lag1^(rig$n_samples - 1)                   # t is scaled to [0, 1]
noise_sd <- 300                                     # N; AR(1) with lag-one correlation 0.5
noise_lag1 <- 0.5
pac_off <- tyre_pac2002(qFz2 = 0, qV2 = 0, qpFz1 = 0)
p_meas <- 2.5e5                                     # single-pressure design (p0 = 2.2 bar)
camber_meas <- 0.1                                  # rad; single-camber design

# Operating conditions of a design: one row per (speed, camber) combination.
tyre_conditions <- function(speeds = 20, cambers = camber_meas) {
  expand.grid(speed = speeds, camber = cambers)
}

# Outputs of one effect for every base theta, at every condition x height
# (blocks by condition, then height). `effect` NULL is the Fiala base model,
# which ignores camber. Base and candidates use point-follower contact (the
# Fiala default was point when the shipped results were made; it is now the
# contact patch), so "disc" is the only contact effect.
tyre_runs <- function(theta, effect = NULL, strength = 0, conditions = tyre_conditions()) {
  blocks <- lapply(seq_len(nrow(conditions)), function(j) {
    v <- conditions$speed[j]
    g <- conditions$camber[j]
    if (is.null(effect) || strength == 0) {
      return(tyre_cleat_model(as.matrix(theta), height = heights, speed = v, rig = rig,
                              contact = "point"))
    }
    switch(effect,
      quadratic = tyre_cleat_model(as.matrix(theta), height = heights, speed = v, rig = rig,
                                   model = "pac2002", contact = "point",
                                   pac = tyre_pac2002(qFz2 = strength, qV2 = 0, qpFz1 = 0)),
      disc = tyre_cleat_model(as.matrix(theta), height = heights, speed = v, rig = rig,
                              model = "pac2002", contact = "disc", pac = pac_off),
      speed = tyre_cleat_model(as.matrix(theta), height = heights, speed = v, rig = rig,
                               model = "pac2002", contact = "point",
                               pac = tyre_pac2002(qFz2 = 0, qV2 = strength, qpFz1 = 0)),
      pressure = tyre_cleat_model(as.matrix(theta), height = heights, speed = v, rig = rig,
                                  model = "pac2002", contact = "point", pressure = p_meas,
                                  pac = tyre_pac2002(qFz2 = 0, qV2 = 0, qpFz1 = strength)),
      camber = tyre_cleat_model(as.matrix(theta), height = heights, speed = v, rig = rig,
                                model = "pac2002", contact = "point", camber = g,
                                pac = tyre_pac2002(qFz2 = 0, qFz3 = strength, qV2 = 0,
                                                   qpFz1 = 0)))
  })
  out <- do.call(cbind, blocks)
  attributes(out) <- list(dim = dim(out))
  out
}

tyre_grids <- list(quadratic = c(0, 5, 10, 15, 20, 25, 30), disc = c(0, 1),
                   speed = c(0, 0.05, 0.1, 0.15, 0.2), pressure = c(0, 0.3, 0.6, 0.9, 1.2),
                   camber = c(0, 50, 100, 150, 200, 250))
# qFz3 = 100 at 0.1 rad adds 1 to qFz1 (about 20 here): a 5% stiffer tyre.
tyre_truth_range <- list(quadratic = c(8, 25), disc = c(1, 1), speed = c(0.06, 0.2),
                         pressure = c(0.4, 1.2), camber = c(60, 250))

# x: height plus whichever of speed and camber varies between conditions.
tyre_design <- function(conditions, effects = names(tyre_grids)) {
  x <- cbind(height = rep(heights, nrow(conditions)),
             conditions[rep(seq_len(nrow(conditions)), each = length(heights)), , drop = FALSE])
  x <- x[c("height", names(conditions)[vapply(conditions, function(v) length(unique(v)) > 1,
                                              logical(1))])]
  rownames(x) <- NULL
  t <- seq_len(rig$n_samples) * rig$sample_interval
  base <- sim_library(base_theta, tyre_runs(base_theta, conditions = conditions), x = x, t = t)
  cands <- lapply(stats::setNames(effects, effects), function(e) {
    parts <- lapply(tyre_grids[[e]], function(s) tyre_runs(base_theta, e, s, conditions))
    th <- do.call(rbind, lapply(tyre_grids[[e]], function(s) cbind(base_theta, strength = s)))
    names(th)[3] <- e
    sim_library(th, do.call(rbind, parts), x = x, t = t)
  })
  list(base = base, candidates = cands, conditions = conditions, x = x, t = t)
}

ar1_noise <- function(n_blocks, n_t, sd, lag1) {
  as.vector(vapply(seq_len(n_blocks), function(b) {
    e <- numeric(n_t)
    e[1] <- stats::rnorm(1, sd = sd)
    for (i in 2:n_t) e[i] <- lag1 * e[i - 1] + stats::rnorm(1, sd = sd * sqrt(1 - lag1^2))
    e
  }, numeric(n_t)))
}

# One trial: truth theta at a library node (so library resolution is not
# mistaken for a gap; the off-grid scenario checks that separately), with k
# low enough that the stiffening effects keep the recalibrated k inside the
# library's range (150-300 N/mm): at the range's edge a scale effect is no
# longer imitable by k and would look like a genuine gap.
tyre_trial <- function(design, scenario, truth, offered, seed, off_grid = FALSE,
                       bump = 0) {
  set.seed(seed)
  node <- sample(which(base_theta$k >= 160 & base_theta$k <= 220 & base_theta$c >= 0.4 &
                         base_theta$c <= 1.2), 1)
  theta <- base_theta[node, ]
  if (off_grid) theta <- theta + c(stats::runif(1, -2.5, 2.5), stats::runif(1, -0.05, 0.05))
  strength <- if (truth == "none") 0 else stats::runif(1, tyre_truth_range[[truth]][1],
                                                       tyre_truth_range[[truth]][2])
  clean <- drop(tyre_runs(theta, if (truth == "none") NULL else truth, strength,
                          design$conditions))
  n_t <- length(design$t)
  y <- clean + ar1_noise(nrow(design$x), n_t, noise_sd, noise_lag1)
  bump_block <- NA_integer_
  if (bump > 0) {
    bump_block <- 2L                                 # second setting, pulse at 55 ms
    idx <- (bump_block - 1L) * n_t + seq_len(n_t)
    y[idx] <- y[idx] + bump * exp(-((design$t - 0.055) / 0.003)^2)
  }
  field <- field_data(matrix(y, nrow(design$x), byrow = TRUE), x = design$x, t = design$t)
  fit <- suppressWarnings(calibrate(design$base, field, rho_t = rho_t, n_iter = 200,
                                    burn_in = 50, seed = 1))
  gap <- diagnose_gap(fit, design$candidates[offered], max_runs = max_runs, seed = seed)
  list(gap = gap, row = trial_row(gap, "tyre", scenario, truth, strength, offered, seed,
                                  bump_block, bump_t = 0.055))
}

trial_row <- function(gap, system, scenario, truth, strength, offered, seed, bump_block,
                      bump_t = NA_real_) {
  w <- gap$which
  sh <- gap$shrinkage
  p <- stats::setNames(w$prob, w$effect)
  conf <- stats::setNames(w$confounded, w$effect)
  wh <- gap$where
  bump_hit <- NA
  false_flags <- sum(wh$flagged)
  if (!is.na(bump_block)) {
    at <- wh$x == bump_block & wh$from <= bump_t & wh$to >= bump_t
    bump_hit <- any(wh$flagged[at])
    false_flags <- sum(wh$flagged[!at])
  }
  decoys <- setdiff(sh$effect, truth)
  data.table(system = system, scenario = scenario, seed = seed, truth = truth,
             strength = strength, offered = paste(offered, collapse = "+"),
             answer = gap$verdict$answer, reason = gap$verdict$reason, top = w$effect[1],
             prob_top = w$prob[1],
             prob_none = p[["none"]], prob_other = p[["other"]],
             prob_truth = if (truth %in% names(p)) p[[truth]] else NA_real_,
             confounded = paste(names(conf)[conf], collapse = "+"),
             shrink_truth = if (truth %in% sh$effect) sh$shrink[sh$effect == truth] else NA_real_,
             shrink_decoy_max = if (length(decoys)) max(sh$shrink[sh$effect %in% decoys]) else NA_real_,
             shrink_decoy_median = if (length(decoys)) stats::median(sh$shrink[sh$effect %in% decoys]) else NA_real_,
             lpd_gain_truth = if (truth %in% sh$effect) sh$lpd_after[sh$effect == truth] - sh$lpd_before[1] else NA_real_,
             cover90_truth = if (truth %in% sh$effect) sh$cover90_after[sh$effect == truth] else NA_real_,
             cover90_none = sh$cover90_before[1],
             n_blocks = nrow(wh), n_flagged = sum(wh$flagged), bump_hit = bump_hit,
             false_flags = false_flags)
}

all_tyre <- names(tyre_grids)
tyre_scenarios <- list(
  list(id = "T0 null", truth = "none", offered = all_tyre),
  list(id = "T0b null, theta off the library grid", truth = "none", offered = all_tyre,
       off_grid = TRUE),
  list(id = "T1 quadratic stiffness", truth = "quadratic", offered = all_tyre),
  list(id = "T1b quadratic stiffness, theta off the library grid", truth = "quadratic",
       offered = all_tyre, off_grid = TRUE),
  list(id = "T2 rigid-disc contact", truth = "disc", offered = all_tyre),
  list(id = "T3 quadratic stiffness withheld", truth = "quadratic",
       offered = setdiff(all_tyre, "quadratic")),
  list(id = "T4 rigid-disc contact withheld", truth = "disc", offered = setdiff(all_tyre, "disc")),
  list(id = "T5 speed stiffening, one speed (confounded)", truth = "speed", offered = all_tyre),
  list(id = "T6 speed stiffening, two speeds", truth = "speed",
       offered = c("quadratic", "disc", "speed"), speeds = c(12, 28)),
  list(id = "T8 camber stiffening, one camber (confounded)", truth = "camber",
       offered = all_tyre),
  list(id = "T9 camber stiffening, cambers 0 and 0.1 rad", truth = "camber",
       offered = c("quadratic", "disc", "camber"), cambers = c(0, camber_meas)),
  list(id = "T7 planted local discrepancy (null model)", truth = "none", offered = all_tyre,
       bump = 1500)
)

designs <- list()
rows <- list()
examples <- list()
for (sc in Filter(wanted, tyre_scenarios)) {
  conditions <- tyre_conditions(if (is.null(sc$speeds)) 20 else sc$speeds,
                                if (is.null(sc$cambers)) camber_meas else sc$cambers)
  key <- paste(c(conditions$speed, conditions$camber), collapse = "-")
  if (is.null(designs[[key]])) {
    designs[[key]] <- tyre_design(conditions, if (nrow(conditions) == 1L) all_tyre else
      intersect(all_tyre, sc$offered))
  }
  cli::cli_inform("{sc$id}: {n_trials_tyre} trials")
  for (i in seq_len(n_trials_tyre)) {
    res <- tyre_trial(designs[[key]], sc$id, sc$truth, sc$offered, seed = 1000 + i,
                      off_grid = isTRUE(sc$off_grid), bump = if (is.null(sc$bump)) 0 else sc$bump)
    rows[[length(rows) + 1L]] <- res$row
    if (i == 1L) {
      examples[[sc$id]] <- res$gap[c("where", "which", "shrinkage", "folds", "map", "verdict",
                                     "settings", "x", "t")]
    }
  }
}
for (nm in names(examples)) class(examples[[nm]]) <- "gap_diagnosis"
tyre_seconds <- proc.time()[["elapsed"]] - started

# ---- piston -------------------------------------------------------------------
truth_htc <- c(1000, 3000, 2000)
axes <- lapply(truth_htc, function(h) h * exp(seq(log(0.5), log(2), length.out = 9)))
p_theta <- expand.grid(htc_undercrown = axes[[1]], htc_gallery1 = axes[[2]],
                       htc_gallery2 = axes[[3]])
p_x <- piston_library_settings(1:27, "full")
p_grids <- list(gradient = seq(0, 0.8, by = 0.05),
                conductivity = seq(0, -2e-4, by = -1e-5))
p_truth_range <- list(gradient = c(0.3, 0.8), conductivity = c(-1.5e-4, -0.5e-4))
p_runs <- function(theta, effect = "none", strength = 0) {
  unname(piston_model(as.matrix(theta),
                      gallery_gradient = if (effect == "gradient") strength else 0,
                      conductivity_slope = if (effect == "conductivity") strength else 0))
}
p_base <- sim_library(p_theta, p_runs(p_theta), x = p_x)
p_cands <- lapply(stats::setNames(names(p_grids), names(p_grids)), function(e) {
  th <- do.call(rbind, lapply(p_grids[[e]], function(s) cbind(p_theta, strength = s)))
  names(th)[4] <- e
  sim_library(th, do.call(rbind, lapply(p_grids[[e]], function(s) p_runs(p_theta, e, s))),
              x = p_x)
})

# Off the grid: each HTC moved by up to half a (log) step of the library.
piston_trial <- function(scenario, truth, offered, seed, off_grid = FALSE) {
  set.seed(seed)
  node <- sample(which(Reduce(`&`, Map(function(v, h) v > 0.55 * h & v < 1.8 * h, p_theta,
                                       truth_htc))), 1)
  theta <- p_theta[node, ]
  if (off_grid) theta <- theta * exp(stats::runif(3, -1, 1) * log(4) / 16)
  strength <- if (truth == "none") 0 else stats::runif(1, p_truth_range[[truth]][1],
                                                       p_truth_range[[truth]][2])
  clean <- drop(p_runs(theta, truth, strength))
  field <- field_data(clean + stats::rnorm(27, sd = sqrt(0.4)), x = p_x)
  fit <- suppressWarnings(calibrate(p_base, field, n_iter = 200, burn_in = 50, seed = 1))
  gap <- diagnose_gap(fit, p_cands[offered], max_runs = max_runs, seed = seed)
  list(gap = gap, row = trial_row(gap, "piston", scenario, truth, strength, offered, seed,
                                  NA_integer_))
}

piston_scenarios <- list(
  list(id = "P0 null", truth = "none", offered = names(p_grids)),
  list(id = "P0b null, theta off the library grid", truth = "none", offered = names(p_grids),
       off_grid = TRUE),
  list(id = "P1 graded gallery HTC", truth = "gradient", offered = names(p_grids)),
  list(id = "P1b graded gallery HTC, theta off the library grid", truth = "gradient",
       offered = names(p_grids), off_grid = TRUE),
  list(id = "P2 temperature-dependent conductivity", truth = "conductivity",
       offered = names(p_grids)),
  list(id = "P3 graded gallery HTC withheld", truth = "gradient", offered = "conductivity"),
  list(id = "P4 conductivity withheld", truth = "conductivity", offered = "gradient")
)
for (sc in Filter(wanted, piston_scenarios)) {
  cli::cli_inform("{sc$id}: {n_trials_piston} trials")
  for (i in seq_len(n_trials_piston)) {
    res <- piston_trial(sc$id, sc$truth, sc$offered, seed = 2000 + i,
                        off_grid = isTRUE(sc$off_grid))
    rows[[length(rows) + 1L]] <- res$row
    if (i == 1L) {
      examples[[sc$id]] <- res$gap[c("where", "which", "shrinkage", "folds", "map", "verdict",
                                     "settings", "x", "t")]
      class(examples[[sc$id]]) <- "gap_diagnosis"
    }
  }
}
trials <- rbindlist(rows)
runtime <- c(tyre = tyre_seconds, piston = proc.time()[["elapsed"]] - started - tyre_seconds)
print(runtime)
if (nzchar(subset_out)) {
  trials[, max_runs := max_runs]
  fwrite(trials, subset_out)
  print(trials[, .(trials = .N, right = mean(answer == truth)), by = scenario])
  quit(save = "no")
}
fwrite(trials, "inst/extdata/gap_validation_trials.csv.gz")
saveRDS(list(examples = examples, runtime = runtime,
             n_trials = c(tyre = n_trials_tyre, piston = n_trials_piston),
             settings = list(noise_sd = noise_sd, noise_lag1 = noise_lag1, lag1_grid = lag1,
                             tyre_grids = tyre_grids, tyre_truth_range = tyre_truth_range,
                             piston_grids = p_grids, piston_truth_range = p_truth_range,
                             base_theta = "k 150-300 by 5 N/mm x c 0.3-1.3 by 0.1 N s/mm",
                             piston_theta = "9 log-spaced values per HTC, 0.5-2 x (1000, 3000, 2000)")),
        "inst/extdata/gap_validation_examples.rds", compress = "xz")
