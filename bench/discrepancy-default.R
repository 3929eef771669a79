# Issue 33, item 3: which default for gp_discrepancy()'s `orthogonal`?
# Measured on four small closed-form systems griddy has not seen (written
# here), each with one experiment per setting and with 3 replicates:
#   cooling   Newton's law T = 20 + (T0 - 20) exp(-h t), theta = h; reality
#             also radiates, dT/dt = -h (T - 20) - c ((T + 273.15)^4 -
#             293.15^4), c = 7e-11 (about a fifth of the heat loss at 90 C);
#             T0 = 50, 70, 90 C (x), 20 times 2-40 min, noise sd 0.3 C.
#   pk        a one-compartment drug curve, theta = (k_a, k_e), doses 1, 2, 4
#             (x), 16 times 0.5-12 h, noise sd 0.05; reality has a second
#             peak of 5 noise sds at t = 6 h (sd 0.5 h) at dose 2 only.
#   machine   Brynjarsdottir and O'Hagan's simple machine: simulator theta x,
#             reality theta x / (1 + x / 20); 11 settings on [0.2, 4], noise
#             sd 0.01.
#   logistic  NO gap: logistic growth y = 1 / (1 + (1 / y0 - 1) exp(-r t)),
#             theta = r, y0 = 0.02, 0.05, 0.1 (x), 15 times 1-15, noise sd
#             0.02; a fine library and a coarse one (r every 0.02: the
#             nearest run misses the data by up to ~1 noise sd per point).
# The physical theta is drawn per trial inside the library's box (off its
# grid). The best-fitting theta* is the L2 projection of Tuo and Wu (2015),
# argmin_theta sum (reality - simulator(theta))^2 over the observed settings
# and times, computed with optimize()/optim() on the closed forms.
#
# Per trial three fits through calibrate() (n_iter 4000, burn-in 1000): no
# discrepancy ("none"), gp_discrepancy() (orthogonal, the default: "orth")
# and gp_discrepancy(orthogonal = FALSE) (Kennedy-O'Hagan: "koh"). theta's
# 95% equal-tailed interval is read from the fit's exact posterior over the
# runs (posterior_exact(fit, joint = FALSE), no Monte Carlo error), per
# parameter; log Bayes factor from discrepancy_evidence(fit) (for "none",
# the gap screen's); which warnings calibrate() gave (gap, resolution);
# calibrate()'s elapsed time (a loaded 2-core machine: read ratios).
#
# Run from the package root: Rscript bench/discrepancy-default.R [seeds]
# (default 15 seeds per arm; ~5-10 min here). Writes
# bench/results/discrepancy-default.csv and prints the summary table that
# bench/results/discrepancy-default.md reports.
pkgload::load_all(".", quiet = TRUE)
options(width = 250)
args <- commandArgs(trailingOnly = TRUE)
n_seeds <- if (length(args) >= 1L) as.integer(args[1]) else 15L

# ---- the systems ----------------------------------------------------------
# Each: x (settings), t (outputs), sim(theta) (an n_x x n_t matrix for one
# theta, a named vector), reality(truth), draw() (a physical theta), noise,
# grids (library theta grids, fine and, where studied, coarse).

cooling <- local({
  x <- data.frame(T0 = c(50, 70, 90))
  t <- seq(2, 40, by = 2)
  sim <- function(th) outer(x$T0 - 20, exp(-th[["h"]] * t)) + 20
  reality <- function(th) {
    # RK4, step 0.05 min, all three settings at once
    f <- function(T) -th[["h"]] * (T - 20) - 7e-11 * ((T + 273.15)^4 - 293.15^4)
    dt <- 0.05
    T <- x$T0
    out <- matrix(NA_real_, nrow(x), length(t))
    for (k in seq_len(round(max(t) / dt))) {
      k1 <- f(T); k2 <- f(T + dt / 2 * k1); k3 <- f(T + dt / 2 * k2); k4 <- f(T + dt * k3)
      T <- T + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
      hit <- which(abs(t - k * dt) < 1e-9)
      if (length(hit)) out[, hit] <- T
    }
    out
  }
  list(x = x, t = t, sim = sim, reality = reality, noise = 0.3,
       draw = function() c(h = stats::runif(1, 0.045, 0.055)),
       grids = list(fine = list(h = seq(0.04, 0.075, by = 1e-5))))
})

pk <- local({
  x <- data.frame(dose = c(1, 2, 4))
  t <- seq(0.5, 12, length.out = 16)
  sim <- function(th) {
    ka <- th[["k_a"]]; ke <- th[["k_e"]]
    outer(x$dose, ka / (ka - ke) * (exp(-ke * t) - exp(-ka * t)))
  }
  reality <- function(th) {
    y <- sim(th)
    y[2, ] <- y[2, ] + 5 * 0.05 * exp(-0.5 * ((t - 6) / 0.5)^2)
    y
  }
  list(x = x, t = t, sim = sim, reality = reality, noise = 0.05,
       draw = function() c(k_a = stats::runif(1, 1.4, 1.6), k_e = stats::runif(1, 0.1925, 0.2075)),
       grids = list(fine = list(k_a = seq(1.3, 1.7, length.out = 101),
                                k_e = seq(0.185, 0.215, length.out = 151))))
})

machine <- local({
  x <- data.frame(x = seq(0.2, 4, length.out = 11))
  list(x = x, t = NULL, sim = function(th) matrix(th[["theta"]] * x$x),
       reality = function(th) matrix(th[["theta"]] * x$x / (1 + x$x / 20)), noise = 0.01,
       draw = function() c(theta = stats::runif(1, 0.6, 0.7)),
       grids = list(fine = list(theta = seq(0.3, 1, by = 1e-4))))
})

logistic <- local({
  x <- data.frame(y0 = c(0.02, 0.05, 0.1))
  t <- seq(1, 15, by = 1)
  sim <- function(th) 1 / (1 + outer(1 / x$y0 - 1, exp(-th[["r"]] * t)))
  list(x = x, t = t, sim = sim, reality = sim, noise = 0.02,
       draw = function() c(r = stats::runif(1, 0.55, 0.65)),
       grids = list(fine = list(r = seq(0.5, 0.7, by = 2.5e-4)),
                    coarse = list(r = seq(0.4, 0.8, by = 0.02))))
})

systems <- list(cooling = cooling, pk = pk, machine = machine, logistic = logistic)

build_library <- function(sys, grid) {
  theta <- expand.grid(grid)
  Y <- t(apply(theta, 1, function(th) as.vector(t(sys$sim(th)))))
  if (is.null(sys$t)) return(sim_library(theta, Y, x = sys$x))
  sim_library(theta, Y, x = sys$x, t = sys$t)
}

# The L2 projection: the theta whose simulator output is closest to reality
# over the observed settings and times (replicates weigh every setting alike,
# so they leave it unchanged), started at the physical value.
best_fitting <- function(sys, truth, grid) {
  target <- sys$reality(truth)
  loss <- function(v) sum((target - sys$sim(stats::setNames(v, names(truth))))^2)
  if (length(truth) == 1L) {
    r <- range(grid[[1]])
    return(stats::setNames(stats::optimize(loss, r, tol = 1e-10)$minimum, names(truth)))
  }
  o <- stats::optim(truth, loss, method = "Nelder-Mead",
                    control = list(reltol = 1e-14, maxit = 5000))
  stats::setNames(o$par, names(truth))
}

fits <- list(none = NULL, orth = gp_discrepancy(), koh = gp_discrepancy(orthogonal = FALSE))

# Equal-tailed interval of each parameter's exact marginal over the runs.
exact_intervals <- function(fit, theta) {
  p <- posterior_exact(fit, joint = FALSE)$run
  lapply(stats::setNames(names(theta), names(theta)), function(nm) {
    m <- tapply(p, theta[[nm]], sum)
    v <- as.numeric(names(m))
    cp <- cumsum(m) / sum(m)
    c(lower = v[which(cp >= 0.025)[1]], upper = v[which(cp >= 0.975)[1]],
      mean = sum(v * m) / sum(m))
  })
}

trial <- function(sys_name, lib_name, lib, reps, seed) {
  sys <- systems[[sys_name]]
  set.seed(seed)
  truth <- sys$draw()
  grid <- sys$grids[[lib_name]]
  best <- best_fitting(sys, truth, grid)
  real <- sys$reality(truth)
  rows <- rep(seq_len(nrow(sys$x)), each = reps)
  y <- real[rows, , drop = FALSE]
  y <- y + stats::rnorm(length(y), sd = sys$noise)
  xr <- sys$x[rows, , drop = FALSE]
  field <- if (is.null(sys$t)) field_data(y, x = xr) else field_data(y, x = xr, t = sys$t)
  theta <- lib_theta(lib)
  out <- list()
  for (nm in names(fits)) {
    classes <- character(0)
    start <- proc.time()[["elapsed"]]
    fit <- withCallingHandlers(
      calibrate(lib, field, discrepancy = fits[[nm]], n_iter = 4000, burn_in = 1000,
                seed = seed),
      warning = function(w) {
        classes <<- c(classes, class(w)[1])
        invokeRestart("muffleWarning")
      })
    secs <- proc.time()[["elapsed"]] - start
    iv <- exact_intervals(fit, theta)
    log_bf <- if (is.null(fits[[nm]])) {
      if (is.null(fit$gap_screen)) NA_real_ else fit$gap_screen$log_bf
    } else discrepancy_evidence(fit)$log_bayes_factor
    for (p in names(truth)) {
      out[[length(out) + 1L]] <- data.frame(
        system = sys_name, library = lib_name, reps = reps, seed = seed, fit = nm,
        parameter = p, truth = truth[[p]], best = best[[p]], lower = iv[[p]][["lower"]],
        upper = iv[[p]][["upper"]], mean = iv[[p]][["mean"]],
        width = iv[[p]][["upper"]] - iv[[p]][["lower"]],
        covers_truth = iv[[p]][["lower"]] <= truth[[p]] && truth[[p]] <= iv[[p]][["upper"]],
        covers_best = iv[[p]][["lower"]] <= best[[p]] && best[[p]] <= iv[[p]][["upper"]],
        log_bf = log_bf, gap_warned = "griddy_warning_gap" %in% classes,
        resolution_warned = "griddy_warning_resolution" %in% classes,
        other_warnings = paste(setdiff(unique(classes), c("griddy_warning_gap",
                                                          "griddy_warning_resolution")),
                               collapse = " "),
        seconds = secs)
    }
  }
  do.call(rbind, out)
}

arms <- list(
  list("cooling", "fine"), list("pk", "fine"), list("machine", "fine"),
  list("logistic", "fine"), list("logistic", "coarse"))
res <- list()
t_all <- proc.time()[["elapsed"]]
for (arm in arms) {
  sys_name <- arm[[1]]
  lib_name <- arm[[2]]
  lib <- build_library(systems[[sys_name]], systems[[sys_name]]$grids[[lib_name]])
  for (reps in c(1L, 3L)) {
    for (i in seq_len(n_seeds)) {
      seed <- 1000L * match(sys_name, names(systems)) + 100L * (lib_name == "coarse") +
        10L * reps + i
      r <- trial(sys_name, lib_name, lib, reps, seed)
      res[[length(res) + 1L]] <- r
      s <- r[r$parameter == r$parameter[1], ]
      message(sprintf("%s/%s reps %d seed %d: covers truth %s best %s; width/none %s; logBF %s",
                      sys_name, lib_name, reps, seed,
                      paste(as.integer(s$covers_truth), collapse = ""),
                      paste(as.integer(s$covers_best), collapse = ""),
                      paste(format(s$width / s$width[1], digits = 2), collapse = " "),
                      paste(format(s$log_bf, digits = 3), collapse = " ")))
    }
  }
}
res <- do.call(rbind, res)
res$machine_load <- as.numeric(strsplit(readLines("/proc/loadavg"), " ")[[1]][1])
none_width <- with(res[res$fit == "none", ],
                   stats::setNames(width, paste(system, library, reps, seed, parameter)))
res$width_ratio <- res$width / none_width[with(res, paste(system, library, reps, seed, parameter))]
dir.create("bench/results", showWarnings = FALSE)
utils::write.csv(res, "bench/results/discrepancy-default.csv", row.names = FALSE)

range_txt <- function(v, digits = 2) {
  v <- v[is.finite(v)]
  if (!length(v)) return("-")
  f <- function(z) formatC(z, format = "f", digits = digits)
  paste0(f(stats::median(v)), " (", f(min(v)), " to ", f(max(v)), ")")
}
# by system x library x replicates x parameter x fit; the width ratio is to
# the fit without a discrepancy on the same data (a coarse library's interval
# can be a single run, width 0: no ratio)
tab <- do.call(rbind, lapply(split(res, list(res$system, res$library, res$reps, res$fit,
                                              res$parameter), drop = TRUE), function(d) {
  n <- nrow(d)
  data.frame(system = d$system[1], library = d$library[1], reps = d$reps[1],
             parameter = d$parameter[1], fit = d$fit[1],
             covers_physical = paste0(sum(d$covers_truth), "/", n),
             covers_best = paste0(sum(d$covers_best), "/", n),
             width_vs_none = range_txt(d$width_ratio),
             median_width = signif(stats::median(d$width), 2),
             log_bf = range_txt(d$log_bf, 1),
             gap_warned = paste0(sum(d$gap_warned), "/", n),
             resolution_warned = paste0(sum(d$resolution_warned), "/", n),
             seconds = round(stats::median(d$seconds), 2))
}))
tab <- tab[order(match(tab$system, names(systems)), tab$library, tab$reps, tab$parameter,
                 match(tab$fit, names(fits))), ]
print(tab, row.names = FALSE)
cat("\n", paste0("| ", paste(names(tab), collapse = " | "), " |"), "\n",
    paste0("|", paste(rep("---", ncol(tab)), collapse = "|"), "|"), "\n", sep = "")
cat(apply(tab, 1, function(r) paste0("| ", paste(trimws(r), collapse = " | "), " |")), sep = "\n")
# time per fit against the fit without a discrepancy on the same data
key <- with(res, paste(system, library, reps, seed))
secs <- res[!duplicated(res[c("system", "library", "reps", "seed", "fit")]), ]
none_secs <- with(secs[secs$fit == "none", ], stats::setNames(seconds, paste(system, library,
                                                                             reps, seed)))
secs$ratio <- secs$seconds / none_secs[with(secs, paste(system, library, reps, seed))]
cat("\ntime per fit / no discrepancy's, median (range) over all trials:\n")
print(tapply(secs$ratio, secs$fit, range_txt))
cat(sprintf("\n%d trials, %.1f min in all, load average %.1f at the end\n",
            length(unique(key)), (proc.time()[["elapsed"]] - t_all) / 60, res$machine_load[1]))
