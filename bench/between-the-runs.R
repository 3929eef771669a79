# Between the runs: coverage and width of the 95% intervals when the truth
# lies between the library's runs, for a plain fit, refine() with the
# simulator and refine() without it (issue 12). Systems of our own making,
# none of which the package was tuned on:
#   oscillator: y = a * exp(-c t) sin(k t) at 4 amplitudes a x 60 times,
#               theta = (k, c): 240 data points; libraries a 49 x 26 grid,
#               a 1,274-run Latin hypercube and a coarse 12 x 7 grid;
#   projectile: height of a projectile with quadratic drag at 30 times for 3
#               launch speeds, theta = (angle, drag): a 3,000-run hypercube;
#   piston:     the package's piston stand-in, 3 heat-transfer coefficients,
#               54 data points, a 10^3 grid.
# The continuous posterior's interval is the Laplace one: +-1.96 sd from the
# Jacobian at the truth and the true noise sd.
#
# Run: Rscript bench/between-the-runs.R [system] [trials]   (from the package
# root, with griddy installed or loadable); writes
# bench/results/between-the-runs-<system>.csv.
args <- commandArgs(trailingOnly = TRUE)
system_name <- if (length(args) >= 1) args[1] else "oscillator-grid"
n_trials <- if (length(args) >= 2) as.integer(args[2]) else 40L
modes <- if (length(args) >= 3) strsplit(args[3], ",")[[1]] else c("plain", "simulator", "emulator")
if (requireNamespace("pkgload", quietly = TRUE) && file.exists("DESCRIPTION")) {
  pkgload::load_all(".", quiet = TRUE)
} else {
  library(griddy)
}
suppressPackageStartupMessages(requireNamespace("data.table"))

oscillator <- function(theta) {
  t <- seq(0.05, 3, length.out = 60)
  amps <- c(0.5, 1, 1.5, 2)
  t(vapply(seq_len(nrow(theta)), function(i) {
    unlist(lapply(amps, function(a) a * exp(-theta$c[i] * t) * sin(theta$k[i] * t)))
  }, numeric(240)))
}
oscillator_range <- data.frame(k = c(1, 5), c = c(0.1, 1))

projectile <- function(theta) {
  times <- seq(0.1, 3, length.out = 30)
  speeds <- c(20, 25, 30)
  t(vapply(seq_len(nrow(theta)), function(i) {
    unlist(lapply(speeds, function(v0) {
      # height of a projectile with linear-plus-quadratic drag, Euler steps of 5 ms
      a <- theta$angle[i] * pi / 180
      vx <- v0 * cos(a); vy <- v0 * sin(a); y <- 0; out <- numeric(length(times)); k <- 1
      dt <- 0.005
      for (s in seq_len(ceiling(max(times) / dt))) {
        v <- sqrt(vx^2 + vy^2)
        vx <- vx - theta$drag[i] * v * vx * dt
        vy <- vy - (9.81 + theta$drag[i] * v * vy) * dt
        y <- y + vy * dt
        while (k <= length(times) && s * dt >= times[k] - 1e-9) { out[k] <- y; k <- k + 1 }
      }
      out
    }))
  }, numeric(90)))
}
projectile_range <- data.frame(angle = c(20, 70), drag = c(0.001, 0.05))

piston_sim <- function(theta) {
  griddy::piston_model(as.matrix(theta), locations = 1:27, condition = c("full", "part"))
}

lhs <- function(n, range) {
  u <- matrix(vapply(seq_along(range), function(j) (sample.int(n) - runif(n)) / n, numeric(n)), n)
  as.data.frame(stats::setNames(lapply(seq_along(range), function(j)
    range[1, j] + u[, j] * diff(range[, j])), names(range)))
}
grid_of <- function(ns, range) {
  expand.grid(stats::setNames(lapply(seq_along(range), function(j)
    seq(range[1, j], range[2, j], length.out = ns[j])), names(range)))
}

systems <- list(
  "oscillator-grid" = list(sim = oscillator, range = oscillator_range, sd = 0.05,
                           design = function() grid_of(c(49, 26), oscillator_range)),
  "oscillator-lhs" = list(sim = oscillator, range = oscillator_range, sd = 0.05,
                          design = function() lhs(1274, oscillator_range)),
  "oscillator-coarse" = list(sim = oscillator, range = oscillator_range, sd = 0.05,
                             design = function() grid_of(c(12, 7), oscillator_range)),
  "projectile-lhs" = list(sim = projectile, range = projectile_range, sd = 0.1,
                          design = function() lhs(3000, projectile_range))
)
sys <- systems[[system_name]]
if (is.null(sys)) stop("unknown system ", system_name)

set.seed(20261122)
theta_lib <- sys$design()
lib <- sim_library(theta_lib, sys$sim(theta_lib))

laplace_sd <- function(truth) {
  h <- 1e-5 * unlist(diff(as.matrix(sys$range)))
  J <- vapply(seq_along(truth), function(j) {
    up <- truth; dn <- truth
    up[[j]] <- up[[j]] + h[j]; dn[[j]] <- dn[[j]] - h[j]
    (sys$sim(up) - sys$sim(dn))[1, ] / (2 * h[j])
  }, numeric(ncol(lib$y)))
  sqrt(diag(solve(crossprod(J)))) * sys$sd
}

interval_of <- function(fit) {
  tab <- griddy:::resolution_table(griddy:::exact_from_problem(fit)$run, lib_theta_of(fit))
  tab
}
lib_theta_of <- function(fit) griddy:::lib_theta(fit$library)

# The continuous posterior's interval, from the simulator on a 241 x 241 grid
# over +-6 Laplace sd around the truth (2-parameter systems only): the
# reference the refined fits should match.
continuous_row <- function(i, truth, y, cont, warned) {
  sd <- cont / (2 * 1.96)
  axes <- Map(function(v, s) v + seq(-6, 6, length.out = 241) * s, unlist(truth), sd)
  g <- expand.grid(stats::setNames(axes, names(truth)))
  Y <- sys$sim(g)
  lp <- -length(y) / 2 * log(rowSums((Y - matrix(y, nrow(Y), length(y), byrow = TRUE))^2))
  p <- exp(lp - max(lp))
  p <- p / sum(p)
  q <- t(vapply(names(truth), function(j) {
    m <- tapply(p, g[[j]], sum)
    v <- as.numeric(names(m))
    c(v[which(cumsum(m) >= 0.025)[1]], v[which(cumsum(m) >= 0.975)[1]])
  }, numeric(2)))
  data.frame(trial = i, mode = "continuous", parameter = names(truth), truth = unlist(truth),
             lower = q[, 1], upper = q[, 2],
             covered = q[, 1] <= unlist(truth) & unlist(truth) <= q[, 2],
             width_ratio = (q[, 2] - q[, 1]) / cont, limited = FALSE, warned = warned,
             runs_added = 0L, reason = NA, seconds = NA)
}

one_trial <- function(i) {
  set.seed(1000 + i)
  inner <- sys$range
  inner[1, ] <- sys$range[1, ] + 0.1 * unlist(diff(as.matrix(sys$range)))
  inner[2, ] <- sys$range[2, ] - 0.1 * unlist(diff(as.matrix(sys$range)))
  truth <- lhs(1, inner)
  y <- sys$sim(truth)[1, ] + rnorm(ncol(lib$y), sd = sys$sd)
  field <- field_data(matrix(y, 1), t = lib$t)
  cont <- 2 * 1.96 * laplace_sd(truth)
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 200, burn_in = 100, seed = i))
  warned <- any(interval_of(fit)$limited)
  rows <- list()
  for (mode in modes) {
    t0 <- proc.time()[["elapsed"]]
    if (mode == "continuous") {
      rows[[mode]] <- continuous_row(i, truth, y, cont, warned)
      next
    }
    f <- switch(mode, plain = fit,
                simulator = suppressMessages(refine(fit, sys$sim, max_runs = 3000, seed = i)),
                emulator = suppressMessages(refine(fit, NULL, max_runs = 3000, seed = i)))
    secs <- proc.time()[["elapsed"]] - t0
    tab <- interval_of(f)
    rows[[mode]] <- data.frame(trial = i, mode = mode, parameter = tab$parameter,
      truth = unlist(truth), lower = tab$lower, upper = tab$upper,
      covered = tab$lower <= unlist(truth) & unlist(truth) <= tab$upper,
      width_ratio = (tab$upper - tab$lower) / cont, limited = tab$limited,
      warned = warned,
      runs_added = if (is.null(f$refinement)) 0L else f$refinement$runs_added,
      reason = if (is.null(f$refinement)) NA else f$refinement$reason, seconds = secs)
  }
  do.call(rbind, rows)
}

if (n_trials == 0L) stop_here <- TRUE else {
res <- do.call(rbind, lapply(seq_len(n_trials), function(i) {
  out <- tryCatch(one_trial(i), error = function(e) {
    message("trial ", i, ": ", conditionMessage(e)); NULL
  })
  out
}))
dir.create("bench/results", showWarnings = FALSE)
data.table::fwrite(res, file.path("bench/results", paste0("between-the-runs-", system_name, ".csv")))
dt <- data.table::as.data.table(res)
print(dt[, .(coverage = mean(covered), median_width_ratio = median(width_ratio),
             missed_unwarned = sum(!covered & !warned), runs = median(runs_added),
             seconds = median(seconds)), by = .(mode, parameter)])
}
