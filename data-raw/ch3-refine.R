# Chapter 3 between the runs: does refine() give the piston study's intervals
# back their coverage? Precomputed for the section "Between the runs:
# refine()" of vignettes/chapter3.Rmd. Writes inst/extdata/ch3_refine.csv.gz
# and inst/extdata/ch3_refine_session.txt.
#
# For every data size (6, 15, 27, 54 points, no discrepancy, the field data
# of data-raw/ch3.R) and every library size of the thesis (3 to 47 values per
# coefficient), three fits:
#   plain      calibrate() as in data-raw/ch3.R (independent errors,
#              collapsed update, 35,000 iterations, burn-in 15,000, same seed),
#   simulator  refine(plain, simulator) with piston_model() as the simulator,
#   emulator   refine(plain) without one (runs predicted from the library).
# Both refinements may add up to max_runs = 4000 runs (ten rounds of 400 for
# three parameters): generous against the 1,200-2,800 runs they need when
# they resolve on the 54-point data.
# Plus, per data size, the continuous posterior the refined fits should
# approach: the same model (Gamma-normal in tau with calibrate()'s prior,
# uniform prior over the library's range) on a dense grid of theta around the
# least-squares estimate (mode = "continuous"), and the Laplace width at the
# truth with the true noise variance 0.4 (column laplace_width), which does
# not depend on the noise draw. truth_quantile is the continuous posterior's
# probability below the truth: near 0.025 or 0.975, a correct interval for
# this noise draw only just holds the truth.
#
# Run from the package root with the worktree's griddy installed:
#   R_LIBS=<lib> Rscript data-raw/ch3-refine.R
# 9 minutes here (5 minutes of CPU; 2 cores shared with other jobs, load
# about 4), 12 minutes at load 5-6; a third of it building the 14 libraries
# (as in data-raw/ch3.R), 2.5 minutes the continuous reference, the rest the
# 168 fits (refine() with the simulator takes 1-7 s a fit).
# inst/extdata/ch3_refine_session.txt records the run.
library(griddy)
library(data.table)

t_start <- proc.time()[["elapsed"]]
sizes <- c(3, 4, 5, 6, 7, 8, 9, 10, 15, 22, 27, 32, 39, 47)   # values per coefficient
data_sizes <- c(6, 15, 27, 54)
n_iter <- 35000
burn_in <- 15000
data_seed <- 2023               # the field data of data-raw/ch3.R
max_runs <- 4000
truth <- c(htc_undercrown = 1000, htc_gallery1 = 3000, htc_gallery2 = 2000)
noise_var <- 0.4                # eq. 3.12, the variance piston_field_data() draws with
out_dir <- "inst/extdata"

fields <- lapply(setNames(data_sizes, data_sizes), function(n) {
  piston_field_data(n, discrepancy = FALSE, seed = data_seed)
})

# As in data-raw/ch3.R: the 54-point library (27 locations x 2 conditions)
# per size; smaller data sets use the full-load columns of their locations.
subset_library <- function(lib54, field) {
  cols <- if (length(field$y) == 54) 1:54 else attr(field, "locations")
  x <- lib54$x[cols, , drop = FALSE]
  if (length(field$y) < 54) x$condition <- NULL
  sim_library(theta = lib54$theta, y = lib54$y[, cols, drop = FALSE], x = x)
}

# The simulator refine() calls: theta rows -> the outputs of the library
# made by subset_library() for this field, in its column order (blocks by
# condition, the field's locations in order within a block), which is
# piston_model()'s own order for the same locations and conditions. Checked
# against the library's runs below, for every library and data size.
piston_simulator <- function(field) {
  locations <- attr(field, "locations")
  condition <- attr(field, "condition")
  function(theta) {
    unname(piston_model(as.matrix(theta[, names(truth)]), locations = locations,
                        condition = condition))
  }
}

# Evaluate an expression, muffling griddy's resolution warning and its
# warning that a refinement without a simulator rests on a library that
# predicts itself worse than the noise, recording whether each came;
# messages (refine()'s "already resolved") are dropped.
quietly <- function(expr) {
  warned <- FALSE
  emulation_warned <- FALSE
  value <- withCallingHandlers(suppressMessages(expr),
                               griddy_warning_resolution = function(w) {
                                 warned <<- TRUE
                                 invokeRestart("muffleWarning")
                               },
                               griddy_warning_emulation = function(w) {
                                 emulation_warned <<- TRUE
                                 invokeRestart("muffleWarning")
                               })
  list(value = value, warned = warned, emulation_warned = emulation_warned)
}

# One row per coefficient: summary()'s interval and median (from the draws,
# as in data-raw/ch3.R) and the resolution check from the exact posterior.
fit_rows <- function(fit, keys) {
  s <- summary(fit)
  th <- s[match(names(truth), s$parameter), ]
  res <- griddy:::resolution_limited(fit)
  res <- res[match(names(truth), res$parameter), ]
  r <- fit$refinement
  # the box the last round put its runs in: how far refine() had zoomed in
  box <- if (is.null(r)) matrix(NA_real_, 2, length(truth)) else {
    fit$library$rounds[[length(fit$library$rounds)]]$box[, names(truth), drop = FALSE]
  }
  data.table(keys, parameter = names(truth), truth = unname(truth),
             lower = th$lower, median = th$median, upper = th$upper,
             width = th$upper - th$lower,
             covered = th$lower <= truth & truth <= th$upper,
             effective_values = res$effective_values, limited = res$limited,
             n_runs_final = griddy:::lib_n_runs(fit$library),
             runs_added = if (is.null(r)) 0L else r$runs_added,
             rounds = if (is.null(r)) 0L else r$rounds,
             reason = if (is.null(r)) NA_character_ else r$reason,
             last_box_lower = box[1, ], last_box_upper = box[2, ])
}

# ---- the continuous reference ---------------------------------------------------

# Central-difference Jacobian of the model outputs at theta.
jacobian <- function(sim, theta) {
  vapply(seq_along(theta), function(j) {
    h <- 1e-4 * theta[[j]]
    up <- theta; dn <- theta
    up[[j]] <- up[[j]] + h; dn[[j]] <- dn[[j]] - h
    (sim(as.data.frame(as.list(up))) - sim(as.data.frame(as.list(dn))))[1, ] / (2 * h)
  }, numeric(ncol(sim(as.data.frame(as.list(theta))))))
}

# Smallest value whose cumulative weight reaches each probability.
weighted_quantile <- function(v, w, probs) {
  o <- order(v)
  cw <- cumsum(w[o]) / sum(w)
  vapply(probs, function(p) v[o][which(cw >= p)[1]], numeric(1))
}

# The continuous posterior of calibrate()'s model for this field: uniform
# prior over the library's range, tau integrated out (posterior_exact() on a
# library of grid points, all weighed alike). The grid is regular in the
# coordinates that whiten the Laplace covariance at the least-squares
# estimate (a linear map, so a uniform prior stays uniform), 41 points per
# axis over +-h scale units, where h covers the t tails of the posterior
# (n - 3 degrees of freedom with the vague prior: few at 6 points).
continuous_reference <- function(field, sim) {
  y <- as.numeric(field$y)
  n <- length(y)
  ss <- function(th) sum((y - sim(as.data.frame(as.list(th)))[1, ])^2)
  start <- as.list(truth)
  est <- stats::optim(unlist(start), ss, control = list(parscale = truth, reltol = 1e-12,
                                                        maxit = 5000))
  centre <- setNames(est$par, names(truth))
  J <- jacobian(sim, centre)
  s2 <- est$value / (n - length(truth))
  L <- t(chol(s2 * solve(crossprod(J))))
  h <- max(6, 1.2 * stats::qt(0.9995, n - length(truth)))
  z <- as.matrix(expand.grid(rep(list(seq(-h, h, length.out = 41)), 3)))
  theta <- sweep(z %*% t(L), 2, centre, "+")
  rng <- piston_htc_ranges()
  inside <- apply(theta, 1, function(r) all(r >= rng$min & r <= rng$max))
  theta <- setNames(as.data.frame(theta[inside, ]), names(truth))
  lib <- sim_library(theta, sim(theta), x = field$x)
  p <- posterior_exact(lib, field)$run
  # mass on the grid's outer shell: small if the grid holds the posterior
  shell <- sum(p[apply(abs(z[inside, ]), 1, max) >= h * (1 - 1e-9)])
  J0 <- jacobian(sim, truth)
  laplace <- 2 * stats::qnorm(0.975) * sqrt(diag(noise_var * solve(crossprod(J0))))
  rows <- lapply(seq_along(truth), function(j) {
    q <- weighted_quantile(theta[[j]], p, c(0.025, 0.5, 0.975))
    data.table(parameter = names(truth)[j], truth = truth[[j]], lower = q[1], median = q[2],
               upper = q[3], width = q[3] - q[1],
               covered = q[1] <= truth[[j]] & truth[[j]] <= q[3],
               truth_quantile = sum(p[theta[[j]] <= truth[[j]]]),
               laplace_width = laplace[j], least_squares = centre[[j]],
               grid_shell_mass = shell, n_runs_final = nrow(theta))
  })
  rbindlist(rows)
}

# ---- the study ----------------------------------------------------------------------

rows <- list()
build_seconds <- 0
for (n in data_sizes) {
  t0 <- proc.time()[["elapsed"]]
  ref <- continuous_reference(fields[[as.character(n)]],
                              piston_simulator(fields[[as.character(n)]]))
  ref[, `:=`(n_points = n, mode = "continuous", seconds = proc.time()[["elapsed"]] - t0)]
  rows[[length(rows) + 1]] <- ref
  cat(sprintf("continuous reference, %d points: %.1f s\n", n, ref$seconds[1]))
}

for (k in sizes) {
  t0 <- proc.time()[["elapsed"]]
  lib54 <- piston_library(k, locations = 1:27, condition = c("full", "part"))
  build_seconds <- build_seconds + proc.time()[["elapsed"]] - t0
  for (n in data_sizes) {
    field <- fields[[as.character(n)]]
    lib <- subset_library(lib54, field)
    simulator <- piston_simulator(field)
    # the wrapper reproduces the library's runs: first, a middle and last row
    check <- unique(c(1L, (k^3 + 1L) %/% 2L, k^3))
    stopifnot(max(abs(simulator(lib$theta[check, ]) - lib$y[check, ])) < 1e-9)
    keys <- data.table(n_points = n, n_per_dim = k, n_runs = k^3)
    seed <- 1000 * k + n           # the seed of data-raw/ch3.R's fit
    t1 <- proc.time()[["elapsed"]]
    plain <- quietly(calibrate(lib, field, n_iter = n_iter, burn_in = burn_in, seed = seed,
                               progress = FALSE, update = "collapsed"))
    plain_seconds <- proc.time()[["elapsed"]] - t1
    fits <- list(plain = list(fit = plain$value, warned = plain$warned,
                              seconds = plain_seconds))
    for (mode in c("simulator", "emulator")) {
      t1 <- proc.time()[["elapsed"]]
      r <- quietly(refine(plain$value, if (mode == "simulator") simulator, max_runs = max_runs,
                          seed = seed, progress = FALSE))
      fits[[mode]] <- list(fit = r$value, warned = r$warned,
                           emulation_warned = r$emulation_warned,
                           seconds = proc.time()[["elapsed"]] - t1)
    }
    for (mode in names(fits)) {
      row <- fit_rows(fits[[mode]]$fit, keys)
      em <- fits[[mode]]$fit$refinement$emulation_error
      row[, `:=`(mode = mode, plain_warned = plain$warned, warned = fits[[mode]]$warned,
                 emulation_warned = isTRUE(fits[[mode]]$emulation_warned),
                 emulation_error = if (is.null(em)) NA_real_ else em,
                 seconds = fits[[mode]]$seconds)]
      rows[[length(rows) + 1]] <- row
    }
    cat(sprintf("%2d^3 runs, %2d points: covered plain %d, simulator %d (%d runs, %s), emulator %d (%d runs, %s)\n",
                k, n, sum(rows[[length(rows) - 2]]$covered), sum(rows[[length(rows) - 1]]$covered),
                rows[[length(rows) - 1]]$runs_added[1], rows[[length(rows) - 1]]$reason[1],
                sum(rows[[length(rows)]]$covered), rows[[length(rows)]]$runs_added[1],
                rows[[length(rows)]]$reason[1]))
  }
  rm(lib54)
  gc()
}

res <- rbindlist(rows, fill = TRUE)
setcolorder(res, c("n_points", "n_per_dim", "n_runs", "mode", "parameter", "truth", "lower",
                   "median", "upper", "width", "covered"))
fwrite(res, file.path(out_dir, "ch3_refine.csv.gz"))
total <- proc.time()[["elapsed"]] - t_start
writeLines(c(paste("R", getRversion()), paste("griddy", packageVersion("griddy")),
             paste("date", format(Sys.time(), "%Y-%m-%d %H:%M")),
             paste("load", paste(readLines("/proc/loadavg", warn = FALSE), collapse = " ")),
             sprintf("max_runs %d", max_runs),
             sprintf("seconds %.0f (building libraries %.0f)", total, build_seconds)),
           file.path(out_dir, "ch3_refine_session.txt"))
cat(sprintf("done in %.0f s\n", total))
