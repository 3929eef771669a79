# Ridges and products (issue 35, item 1): refine(fit, simulator) at its
# defaults on systems whose posterior is a curved or weakly identified band.
#   ridge-p (p = 4, 6, 8): 80 data points, y_i = sin(pi g_i . z) +
#             0.5 exp(h_i . z / 2) with fixed random g_i, h_i (as smooth-p of
#             bench/many-parameters-systems.R), theta in [0, 1]^p, where z is
#             theta with
#               z1 = th1 * th2, z2 = 0   (th1 and th2 identified only through
#                                         their product: a hyperbolic ridge)
#               z3 = 0.15 th3, z4 = th4 + 1.2 (th3 - 0.5)^2
#                                        (a banana: th3 weakly identified,
#                                         along a parabola in th4)
#             and th5..thp entering plainly; noise sd 0.05; the truth a Latin
#             hypercube point of [0.15, 0.85]^p.
# Library: a 2,000-run Latin hypercube (seed 2024), as bench/many-parameters.R.
# Reference posterior: importance sampling on the true simulator in the
# coordinates the data identify (ridge_reference(); 100,000 draws, its ESS
# kept per trial as `ref_ess`), with griddy's likelihood under a vague noise
# prior, (SS)^(-n/2). (A tempered SMC sampler with random-walk moves was
# tried first: two seeds disagreed on th1's upper bound by 0.2, its moves
# do not travel a curved ridge.)
# Per trial: refine(fit on the library, simulator) at the defaults
# (max_runs 4000), coverage and width ratio against the reference per
# parameter, runs added, seconds, and whether refine() warned
# (griddy_warning_resolution).
# Run: Rscript bench/ridge-systems.R [system] [trials] [first] [tag] [max_runs]
#   e.g. Rscript bench/ridge-systems.R ridge-6 20 1 after
#   (max_runs refine()'s default, 4000, unless given)
# writes bench/results/ridge-systems-<system>-<tag>.csv
args <- commandArgs(trailingOnly = TRUE)
system_name <- if (length(args) >= 1) args[1] else "ridge-6"
n_trials <- if (length(args) >= 2) as.integer(args[2]) else 3L
first_trial <- if (length(args) >= 3) as.integer(args[3]) else 1L
tag <- if (length(args) >= 4) args[4] else "run"
# max_runs: refine()'s default unless given
max_runs_arg <- if (length(args) >= 5) as.integer(args[5]) else NULL
# GRIDDY_LIB=<library>: an installed build (-O2) instead of load_all(), its
# internals (resolution_limited(), load_average()) attached beside it
if (nzchar(Sys.getenv("GRIDDY_LIB"))) {
  library(griddy, lib.loc = Sys.getenv("GRIDDY_LIB"))
  attach(asNamespace("griddy"), name = "griddy_internals", warn.conflicts = FALSE)
} else {
  pkgload::load_all(".", quiet = TRUE)
}
source("bench/many-parameters-systems.R")

ridge_system <- function(p, n = 80) {
  set.seed(350 + p)
  G <- matrix(stats::rnorm(n * p, sd = 1), n, p)
  H <- matrix(stats::rnorm(n * p, sd = 1), n, p)
  features <- function(th) {
    z <- th
    z[, 1] <- th[, 1] * th[, 2]
    z[, 2] <- 0
    z[, 3] <- 0.15 * th[, 3]
    z[, 4] <- th[, 4] + 1.2 * (th[, 3] - 0.5)^2
    z
  }
  sim <- function(theta) {
    z <- features(as.matrix(theta))
    sin(pi * z %*% t(G)) + 0.5 * exp(z %*% t(H) / 2)
  }
  list(sim = sim, lower = rep(0, p), upper = rep(1, p), sd = 0.05,
       names = paste0("th", seq_len(p)), inner = c(0.15, 0.85))
}

# Reference posterior: importance sampling on the true simulator in the
# coordinates the data identify. The outputs depend on theta through
# r = (th1 th2, th4 + 1.2 (th3 - 0.5)^2, th5, ..., thp) and th3, so the
# proposal draws th1 and th3 uniformly over [0, 1] (the ridge's and the
# banana's free directions, whole), and r from a t (df 5) at the least-squares
# fit with twice its Laplace sd (as bench/many-parameters-systems.R), then
# th2 = r1 / th1, th4 = r2 - 1.2 (th3 - 0.5)^2; the proposal's density in
# theta is the t's times th1 (the Jacobian of th2 -> r1). Uniform prior on
# [0, 1]^p, likelihood (SS)^(-n/2). list(lower, upper, ess, mean, cov).
ridge_reference <- function(sys, y, truth, m = 100000L, seed = 1L) {
  set.seed(seed)
  p <- length(truth)
  n <- length(y)
  to_theta <- function(th1, th3, r) {
    th <- matrix(0, nrow(r), p)
    th[, 1] <- th1
    th[, 2] <- r[, 1] / th1
    th[, 3] <- th3
    th[, 4] <- r[, 2] - 1.2 * (th3 - 0.5)^2
    if (p > 4) th[, 5:p] <- r[, -(1:2)]
    th
  }
  r_truth <- c(truth[1] * truth[2], truth[4] + 1.2 * (truth[3] - 0.5)^2, truth[-(1:4)])
  ss <- function(par) {
    sum((sys$sim(to_theta(0.5, par[1], matrix(par[-1], 1))) - y)^2)
  }
  opt <- optim(c(truth[3], r_truth), ss, method = "BFGS")
  h <- optimHess(opt$par[-1], function(r) n / 2 * log(ss(c(opt$par[1], r))))
  S <- (solve(h) + t(solve(h))) / 2 * 4
  R <- chol(S)
  k <- p - 2
  z <- matrix(rnorm(m * k), m, k) %*% R
  r <- sweep(z * sqrt(5 / rchisq(m, 5)), 2, opt$par[-1], "+")
  th1 <- runif(m)
  th3 <- runif(m)
  draws <- to_theta(th1, th3, r)
  inside <- rowSums(draws >= 0 & draws <= 1) == p
  zz <- backsolve(R, t(r) - opt$par[-1], transpose = TRUE)
  lq <- -(5 + k) / 2 * log1p(colSums(zz^2) / 5) + log(th1)
  draws <- draws[inside, , drop = FALSE]
  Y <- sys$sim(draws)
  lp <- -n / 2 * log(rowSums((Y - matrix(y, nrow(Y), n, byrow = TRUE))^2))
  lw <- lp - lq[inside]
  w <- exp(lw - max(lw))
  w <- w / sum(w)
  q <- apply(draws, 2, function(v) {
    o <- order(v)
    cw <- cumsum(w[o])
    c(v[o][which(cw >= 0.025)[1]], v[o][which(cw >= 0.975)[1]])
  })
  moments <- stats::cov.wt(draws, wt = w, method = "ML")
  list(lower = q[1, ], upper = q[2, ], ess = 1 / sum(w^2), mean = moments$center,
       cov = moments$cov)
}

ridge_trial_data <- function(sys, i, lib) {
  set.seed(1000 + i)
  truth <- unlist(lhs(1, sys$lower + sys$inner[1] * (sys$upper - sys$lower),
                      sys$lower + sys$inner[2] * (sys$upper - sys$lower), sys$names))
  y <- sys$sim(matrix(truth, 1))[1, ] + rnorm(ncol(lib$y), sd = sys$sd)
  field <- field_data(matrix(y, 1), t = lib$t)
  list(truth = truth, y = y, field = field, ref = ridge_reference(sys, y, truth, seed = 5000 + i))
}

ridge_trial <- function(sys, i, lib, system_name) {
  d <- ridge_trial_data(sys, i, lib)
  ref <- d$ref
  t0 <- proc.time()[["elapsed"]]
  fit <- suppressWarnings(calibrate(lib, d$field, n_iter = 1000, burn_in = 200, seed = i))
  rt <- refine_timed(fit, sys, control_max_runs(), seed = i)
  r <- rt$fit
  secs <- proc.time()[["elapsed"]] - t0
  tab <- resolution_limited(r)
  data.frame(system = system_name, trial = i, parameter = tab$parameter, truth = d$truth,
             lower = tab$lower, upper = tab$upper,
             covered = tab$lower <= d$truth & d$truth <= tab$upper,
             ref_lower = ref$lower, ref_upper = ref$upper,
             ref_covered = ref$lower <= d$truth & d$truth <= ref$upper, ref_ess = ref$ess,
             width_ratio = (tab$upper - tab$lower) / (ref$upper - ref$lower),
             effective_runs = tab$effective_runs, pareto_k = tab$pareto_k,
             warned = rt$warned,
             runs_added = if (is.null(r$refinement)) 0L else r$refinement$runs_added,
             reason = if (is.null(r$refinement)) "resolved" else r$refinement$reason,
             seconds = secs, simulator_seconds = rt$simulator_seconds,
             machine = paste("load", paste(round(load_average(), 2), collapse = " ")))
}

control_max_runs <- function() if (is.null(max_runs_arg)) griddy_control()$max_runs else max_runs_arg

ridge_by_name <- function(name) ridge_system(as.integer(sub(".*-", "", name)))

if (sys.nframe() == 0L && n_trials > 0L) {
  sys <- ridge_by_name(system_name)
  lib <- lhs_library(sys, 2000L)
  res <- do.call(rbind, lapply(first_trial - 1L + seq_len(n_trials), function(i) {
    out <- ridge_trial(sys, i, lib, system_name)
    print(out[, c("trial", "parameter", "covered", "ref_covered", "width_ratio",
                  "effective_runs", "warned", "runs_added", "reason", "seconds")], digits = 3)
    out
  }))
  dir.create("bench/results", showWarnings = FALSE)
  data.table::fwrite(res, file.path("bench/results", paste0("ridge-systems-", system_name, "-",
                                                            tag, ".csv")))
  dt <- data.table::as.data.table(res)
  print(dt[, .(pairs = .N, coverage = mean(covered), ref_coverage = mean(ref_covered),
               median_width_ratio = median(width_ratio), min_width_ratio = min(width_ratio),
               narrow_unwarned = sum(width_ratio < 0.85 & !warned),
               missed_unwarned = sum(!covered & !warned),
               warned_trials = sum(unique(data.table::data.table(trial, warned))$warned),
               median_seconds = median(unique(data.table::data.table(trial, seconds))$seconds))])
  cat("load:", system("uptime", intern = TRUE), "\n")
}
