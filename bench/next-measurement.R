# Issue 34, item 3: the time of one next_measurement() ranking at 10^5 runs
# and 100 candidate cells (10 x settings x 10 output coordinates), for a
# stream with independent noise, a stream with an AR(1) grid over t
# (rho_t = 0, 0.5, 0.9) and a stream_models() of two such streams; each
# after 2 measurements (the posterior spread over many runs: the most
# components) and after 20 (concentrated). The target: under 1 s.
#
# Library: N random runs of a two-parameter response
# y(x, t) = a (1 + x t) + b sin(6 t + x), x in 1..10, t in [0, 1]. The rival
# model replaces the sine by a quadratic. Times: elapsed (the whole call)
# and the process's CPU time (user + system), which the other jobs on the
# machine inflate less. Field: one run's response plus
# noise sd 0.05, measured at cells drawn at random.
#
# Usage, from the package root, with griddy installed (R CMD INSTALL .; a
# pkgload::load_all() build compiles C++ without optimisation):
#   Rscript bench/next-measurement.R
# Options (environment): NEXT_RUNS (default 1e5), GRIDDY_NEW_LIB (a library
# holding the griddy to test), NEXT_LABEL (default: the short commit of
# HEAD; name it after the griddy installed when that differs). Writes
# bench/results/next-measurement-<label>.csv and .md, and every candidate's
# gains to next-measurement-<label>-gains.csv (to compare two builds'
# rankings). About a minute here.
source("bench/helpers.R")
if (nzchar(new_griddy_lib())) .libPaths(c(new_griddy_lib(), .libPaths()))
suppressPackageStartupMessages(library(griddy))
N <- as.numeric(Sys.getenv("NEXT_RUNS", "1e5"))
xs <- 1:10
tt <- seq(0, 1, length.out = 10)
cells <- expand.grid(t = tt, x = xs)[c("x", "t")]
response <- function(a, b, rival = FALSE) {
  out <- vapply(seq_len(nrow(cells)), function(j) {
    x <- cells$x[j]
    t <- cells$t[j]
    a * (1 + x * t) + b * (if (rival) 6 * t * (1 - t) + x / 10 else sin(6 * t + x))
  }, numeric(length(a)))
  matrix(out, length(a))
}
set.seed(1)
theta <- data.frame(a = runif(N), b = runif(N))
lib <- sim_library(theta, response(theta$a, theta$b), x = data.frame(x = xs), t = tt)
rival <- sim_library(theta, response(theta$a, theta$b, TRUE), x = data.frame(x = xs), t = tt)
truth <- as.vector(response(0.37, 0.61))
order_measured <- sample(nrow(cells))
prior <- list(shape = 1, rate = 1e-3)

feed <- function(s, n) {
  for (j in sort(order_measured[seq_len(n)])) {   # setting by setting, increasing t
    s <- update(s, y = truth[j] + rnorm(1, sd = 0.05), x = cells[j, "x", drop = FALSE],
                t = cells$t[j])
  }
  s
}
elapsed <- function(expr) {
  t0 <- proc.time()
  force(expr)
  t1 <- proc.time()
  c(elapsed = t1[["elapsed"]] - t0[["elapsed"]],
    cpu = t1[["user.self"]] + t1[["sys.self"]] - t0[["user.self"]] - t0[["sys.self"]])
}
label <- Sys.getenv("NEXT_LABEL", system("git rev-parse --short HEAD", intern = TRUE))
rows <- list()
gains <- list()
for (n in c(2, 20)) {
  for (case in c("independent", "ar1", "models")) {
    set.seed(10 + n)
    rho_t <- if (case == "ar1") c(0, 0.5, 0.9) else 0
    s <- feed(griddy_stream(lib, rho_t = rho_t, prior = prior), n)
    obj <- if (case == "models") {
      set.seed(10 + n)
      feed_models <- stream_models(spring = griddy_stream(lib, prior = prior),
                                   rival = griddy_stream(rival, prior = prior))
      feed(feed_models, n)
    } else {
      s
    }
    post <- if (case == "models") posterior_exact(obj$streams$spring) else posterior_exact(s)
    ess <- 1 / sum(post$joint^2)
    times <- vapply(1:3, function(r) elapsed(next_measurement(obj)), numeric(2))
    res <- next_measurement(obj)
    gains[[length(gains) + 1L]] <- data.frame(measurements = n, case = case, res[c("candidate",
      intersect(c("gain", "gain_model"), names(res)))])
    rows[[length(rows) + 1L]] <- data.frame(
      runs = N, measurements = n, case = case, candidates = nrow(res),
      effective_components = round(ess), seconds_median = median(times["elapsed", ]),
      seconds_max = max(times["elapsed", ]), cpu_seconds_median = median(times["cpu", ]),
      best_gain = max(res$gain))
    print(rows[[length(rows)]])
  }
}
out <- do.call(rbind, rows)
dir.create("bench/results", showWarnings = FALSE)
stem <- paste0("bench/results/next-measurement-", label)
write.csv(out, paste0(stem, ".csv"), row.names = FALSE)
all_gains <- do.call(rbind, lapply(gains, function(g) {
  if (is.null(g$gain_model)) g$gain_model <- NA_real_
  g
}))
write.csv(all_gains, paste0(stem, "-gains.csv"), row.names = FALSE)
md <- c("# next_measurement(): time per ranking",
        "",
        paste0("bench/next-measurement.R, griddy at ", label, ", ",
               format(Sys.time(), tz = "UTC", usetz = TRUE), "; R ", getRversion(),
               "; a 2-core machine shared with other jobs (load ",
               paste(round(as.numeric(strsplit(readLines("/proc/loadavg"), " ")[[1]][1:3]),
                           2), collapse = ", "), "): times are upper bounds."),
        "",
        paste(knitr::kable(out, format = "pipe", row.names = FALSE), collapse = "\n"))
writeLines(md, paste0(stem, ".md"))
writeLines(md)
