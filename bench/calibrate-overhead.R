# Issue 36, item 1: calibrate() against the engine inside it. For each
# problem, in one R process: posterior_exact() (the exact posterior: the
# same validation and misfit table C as calibrate(), no sampling) and
# calibrate() with its defaults, the ratio, and calibrate()'s parts
# (fit$runtime: precompute, sampling, checks) with the checks broken down
# (timed apart on the fit: the exact margins, the resolution table, the
# chains' diagnostics, the gap screen, the convergence warning).
#
# Problems (plain data, so that any griddy version reads the same):
#   simple_machine  Brynjarsdottir and O'Hagan's (2014) simple machine:
#                   theta x on 1,001 theta values in [0.3, 1], 11 settings,
#                   reality theta x / (1 + x / 20) at theta = 0.65, sd 0.01
#   three_par_rho   4,096 runs (16^3 grid) of a smooth 3-parameter response
#                   at 50 points over t, AR(1) noise, rho_t grid of 10 points
#   replicated      2,500 runs (50^2), 3 x settings x 20 t, each setting
#                   measured 3 times, rho_t grid of 5 points
#   large_field     10,000 runs (100^2), 5 x settings x 100 t (500 points),
#                   rho_x grid c(0, 0.5), rho_t grid c(0, 0.5, 0.9) (above
#                   the gap screen's 400 cells: no screen)
#
# Times: the first call of each function in the process (posterior_exact()
# first; griddy's first calls load what they use, so these are what a
# fresh session sees), then the median and the fastest of `reps` further
# calls (elapsed seconds) and their CPU seconds per call (user + system,
# every thread: OpenMP's waiting threads spin, so CPU exceeds elapsed on
# small calls).
# The machine is shared, so the ratios are what count.
#
# Run from the package root:
#   R CMD INSTALL -l /tmp/lib-after . && GRIDDY_LIB=/tmp/lib-after Rscript bench/calibrate-overhead.R after
#   (git archive 9daa721 | tar -x -C /tmp/griddy-before; R CMD INSTALL -l /tmp/lib-before
#   /tmp/griddy-before) GRIDDY_LIB=/tmp/lib-before Rscript bench/calibrate-overhead.R before
# The optional argument labels the results:
# bench/results/calibrate-overhead[-<label>].csv.

args <- commandArgs(TRUE)
label <- if (length(args) > 0L) args[1] else "after"
lib <- Sys.getenv("GRIDDY_LIB")
if (nzchar(lib)) {
  library(griddy, lib.loc = lib)
  source_note <- paste("installed in", lib)
} else {
  # without GRIDDY_LIB, the griddy installed (R CMD INSTALL . first: a
  # pkgload tree is not byte-compiled, and the JIT's compiling counts in
  # the first calls)
  library(griddy)
  source_note <- paste("installed in", dirname(find.package("griddy")))
}
source("bench/helpers.R")
G <- asNamespace("griddy")
reps <- as.integer(Sys.getenv("OVERHEAD_REPS", "15"))

overhead_problems <- function() {
  out <- list()
  x <- data.frame(x = seq(0.2, 4, length.out = 11))
  theta <- data.frame(theta = seq(0.3, 1, length.out = 1001))
  set.seed(1)
  yf <- 0.65 * x$x / (1 + x$x / 20) + rnorm(11, sd = 0.01)
  out$simple_machine <- list(theta = theta, y = outer(theta$theta, x$x), x = x, t = NULL,
                             field_y = matrix(yf), field_x = x, args = list())
  th <- expand.grid(a = seq(0.5, 1.5, length.out = 16), b = seq(0, 2, length.out = 16),
                    c = seq(-1, 1, length.out = 16))
  tt <- seq(0, 1, length.out = 50)
  resp <- function(h, t) {
    outer(h[, 1], exp(-2 * t)) + outer(h[, 2], sin(3 * t)) + outer(h[, 3], t^2)
  }
  set.seed(2)
  e <- as.vector(stats::arima.sim(list(ar = 0.6), 50)) * 0.05
  out$three_par_rho <- list(theta = th, y = resp(as.matrix(th), tt), x = NULL, t = tt,
                            field_y = matrix(drop(resp(cbind(1.03, 0.9, 0.1), tt)) + e, 1),
                            field_x = NULL, args = list(rho_t = seq(0, 0.9, by = 0.1)))
  th2 <- expand.grid(a = seq(0, 1, length.out = 50), b = seq(0, 1, length.out = 50))
  xs <- data.frame(x = c(0, 0.5, 1))
  t2 <- seq(0, 1, length.out = 20)
  g2 <- function(a, b) {
    unlist(lapply(xs$x, function(xx) a * exp(-t2 * (1 + xx)) + b * t2 * xx))
  }
  set.seed(3)
  truth <- matrix(g2(0.43, 0.61), 3, 20, byrow = TRUE)
  out$replicated <- list(theta = th2, y = t(mapply(g2, th2$a, th2$b)), x = xs, t = t2,
                         field_y = truth[rep(1:3, each = 3), ] + matrix(rnorm(180, sd = 0.02), 9),
                         field_x = xs[rep(1:3, each = 3), , drop = FALSE],
                         args = list(rho_t = c(0, 0.3, 0.6, 0.8, 0.9)))
  th3 <- expand.grid(a = seq(0, 1, length.out = 100), b = seq(0, 1, length.out = 100))
  x3 <- data.frame(x = seq(0, 1, length.out = 5))
  t3 <- seq(0, 1, length.out = 100)
  g3 <- function(a, b) unlist(lapply(x3$x, function(xx) sin(2 * t3 + a * (1 + xx)) + b * t3^2))
  set.seed(4)
  out$large_field <- list(theta = th3, y = t(mapply(g3, th3$a, th3$b)), x = x3, t = t3,
                          field_y = matrix(g3(0.37, 0.52) + rnorm(500, sd = 0.05), 5,
                                           byrow = TRUE),
                          field_x = x3, args = list(rho_x = c(0, 0.5), rho_t = c(0, 0.5, 0.9)))
  out
}

elapsed <- function(expr) {
  t0 <- proc.time()[["elapsed"]]
  force(expr)
  proc.time()[["elapsed"]] - t0
}
call_times <- function(f, n = reps) vapply(seq_len(n), function(i) elapsed(f()), 0)
median_time <- function(f, n = reps) stats::median(call_times(f, n))
# CPU seconds (user + system, every thread of the process) per call over n
# calls: steadier than elapsed seconds on a shared machine
cpu_time <- function(f, n = reps) {
  t <- system.time(for (i in seq_len(n)) f())
  (t[["user.self"]] + t[["sys.self"]]) / n
}

rows <- list()
for (name in names(overhead_problems())) {
  p <- overhead_problems()[[name]]
  library_ <- griddy::sim_library(p$theta, p$y, x = p$x, t = p$t)
  field <- griddy::field_data(p$field_y, x = p$field_x, t = p$t)
  exact <- function() do.call(griddy::posterior_exact, c(list(library_, field), p$args))
  fit_call <- function() {
    suppressWarnings(do.call(griddy::calibrate, c(list(library_, field, seed = 1), p$args)))
  }
  first_exact <- elapsed(exact())
  first_fit <- elapsed(fit <- fit_call())
  # the median, and the fastest call (the one least slowed by other jobs on
  # a shared machine)
  times_exact <- call_times(exact)
  times_fit <- call_times(fit_call)
  t_exact <- stats::median(times_exact)
  t_fit <- stats::median(times_fit)
  cpu_exact <- cpu_time(exact)
  cpu_fit <- cpu_time(fit_call)
  parts <- vapply(seq_len(reps), function(i) fit_call()$runtime, numeric(3))
  checks <- c(
    exact_margins = median_time(function() G$exact_from_problem(fit, joint = FALSE)),
    resolution = median_time(function() {
      G$resolution_table(fit$exact$run, G$lib_theta(fit$library))
    }),
    diagnostics = median_time(function() G$fit_diagnostics(fit)),
    gap_screen = median_time(function() G$gap_screen(fit)),
    convergence_warning = median_time(function() suppressWarnings(G$warn_convergence(fit))))
  rows[[name]] <- data.frame(
    code = label, problem = name, runs = nrow(p$theta), field_points = length(p$field_y),
    grid_points = nrow(fit$grid), n_iter = fit$control$n_iter, burn_in = fit$control$burn_in,
    first_exact_s = first_exact, first_calibrate_s = first_fit,
    first_ratio = first_fit / first_exact,
    exact_s = t_exact, calibrate_s = t_fit, ratio = t_fit / t_exact,
    min_exact_s = min(times_exact), min_calibrate_s = min(times_fit),
    min_ratio = min(times_fit) / min(times_exact),
    cpu_exact_s = cpu_exact, cpu_calibrate_s = cpu_fit, cpu_ratio = cpu_fit / cpu_exact,
    precompute_s = stats::median(parts[1, ]), sampling_s = stats::median(parts[2, ]),
    checks_s = stats::median(parts[3, ]),
    t(setNames(checks, paste0("check_", names(checks), "_s"))),
    source = source_note, machine = machine_note())
  print(rows[[name]][, c("problem", "n_iter", "first_ratio", "exact_s", "calibrate_s", "ratio",
                         "min_ratio", "cpu_ratio", "sampling_s",
                         "checks_s", paste0("check_", names(checks), "_s"))], digits = 3)
}
out <- do.call(rbind, rows)
file <- file.path("bench/results", paste0("calibrate-overhead-", label, ".csv"))
utils::write.csv(out, file, row.names = FALSE)
message("wrote ", file)
