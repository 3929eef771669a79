# Many parameters (issue 24): refine() with the simulator at p = 4, 6, 8 on
# a cheap smooth simulator of our own, and a bimodal variant.
#   smooth-p: 80 data points, y_i = sin(pi g_i . theta) + 0.5 exp(h_i . theta / 2)
#             with fixed random g_i, h_i; theta in [0, 1]^p; the last two of
#             p >= 6 parameters weakly identified (their g, h scaled by 0.15);
#             noise sd 0.05; a 2,000-run Latin hypercube library, the truth
#             inside (a Latin hypercube point of [0.15, 0.85]^p).
#   sharp-p:  smooth-p with 200 data points and noise sd 0.01 (a posterior
#             about 11 times narrower).
#   bimodal-p: smooth-p with th1 entering as 4 (th1 - 0.5)^2, so th1 and
#             1 - th1 fit equally: two modes of equal mass (truth th1 in
#             0.5 + [0.15, 0.35]); `mirror_mass` is the fit's mass on th1 < 0.5.
# Reference posterior: importance sampling with the exact simulator, from a t
# proposal (df 5) at the least-squares fit with twice its Laplace covariance,
# 40,000 draws, uniform prior on the range, likelihood (SS)^(-n/2) as
# griddy's with a vague noise prior; for bimodal-p, mirrored in th1.
# Run: Rscript bench/many-parameters.R [system] [trials] [max_runs]
#   e.g. Rscript bench/many-parameters.R smooth-8 4 20000
# `seconds` is calibrate() plus refine(); `simulator_seconds` the simulator's
# share; `plain_*` the plain fit on the 2,000-run library.
# writes bench/results/many-parameters-<system>.csv
args <- commandArgs(trailingOnly = TRUE)
system_name <- if (length(args) >= 1) args[1] else "smooth-4"
n_trials <- if (length(args) >= 2) as.integer(args[2]) else 3L
max_runs <- if (length(args) >= 3) as.integer(args[3]) else 20000L
pkgload::load_all(".", quiet = TRUE)

smooth_system <- function(p, n = 80, weak = if (p >= 6) 2L else 0L) {
  set.seed(240 + p)
  G <- matrix(stats::rnorm(n * p, sd = 1), n, p)
  H <- matrix(stats::rnorm(n * p, sd = 1), n, p)
  if (weak > 0) {
    G[, p - seq_len(weak) + 1] <- 0.15 * G[, p - seq_len(weak) + 1]
    H[, p - seq_len(weak) + 1] <- 0.15 * H[, p - seq_len(weak) + 1]
  }
  sim <- function(theta) {
    th <- as.matrix(theta)
    sin(pi * th %*% t(G)) + 0.5 * exp(th %*% t(H) / 2)
  }
  list(sim = sim, lower = rep(0, p), upper = rep(1, p), sd = 0.05,
       names = paste0("th", seq_len(p)), inner = c(0.15, 0.85))
}

# smooth-p with the first parameter folded: it enters as 4 (th1 - 0.5)^2, so
# th1 and 1 - th1 fit equally (two modes, each holding half the posterior)
bimodal_system <- function(p) {
  sys <- smooth_system(p)
  smooth <- sys$sim
  sys$sim <- function(theta) {
    th <- as.matrix(theta)
    th[, 1] <- 4 * (th[, 1] - 0.5)^2
    smooth(th)
  }
  sys$mirror <- TRUE
  sys
}

lhs <- function(n, lower, upper, names) {
  p <- length(lower)
  u <- matrix(vapply(seq_len(p), function(j) (sample.int(n) - runif(n)) / n, numeric(n)), n)
  stats::setNames(as.data.frame(sweep(sweep(u, 2, upper - lower, "*"), 2, lower, "+")), names)
}

# importance sampling reference: list(lower, upper, ess)
reference_posterior <- function(sys, y, truth) {
  p <- length(truth)
  n <- length(y)
  ss <- function(th) sum((sys$sim(matrix(th, 1)) - y)^2)
  opt <- optim(truth, ss, method = "L-BFGS-B", lower = sys$lower, upper = sys$upper)
  h <- optimHess(opt$par, function(th) n / 2 * log(ss(th)))
  S <- tryCatch(solve(h), error = function(e) diag((sys$upper - sys$lower)^2 / 100, p))
  S <- (S + t(S)) / 2 * 4
  R <- chol(S + diag(1e-12, p))
  m <- 40000
  z <- matrix(rnorm(m * p), m, p) %*% R
  chi <- sqrt(5 / rchisq(m, 5))
  draws <- sweep(z * chi, 2, opt$par, "+")
  inside <- rowSums(sweep(draws, 2, sys$lower, ">=") & sweep(draws, 2, sys$upper, "<=")) == p
  draws <- draws[inside, , drop = FALSE]
  Y <- sys$sim(draws)
  lp <- -n / 2 * log(rowSums((Y - matrix(y, nrow(Y), n, byrow = TRUE))^2))
  zz <- backsolve(R, t(draws) - opt$par, transpose = TRUE)
  lq <- -(5 + p) / 2 * log1p(colSums(zz^2) / 5)
  lw <- lp - lq
  w <- exp(lw - max(lw)); w <- w / sum(w)
  q <- apply(draws, 2, function(v) {
    o <- order(v); cw <- cumsum(w[o])
    c(v[o][which(cw >= 0.025)[1]], v[o][which(cw >= 0.975)[1]])
  })
  if (isTRUE(sys$mirror)) {
    # the exact posterior is symmetric in th1 about 0.5: both modes
    mirrored <- draws
    mirrored[, 1] <- 1 - mirrored[, 1]
    draws <- rbind(draws, mirrored)
    w <- c(w, w) / 2
    q <- apply(draws, 2, function(v) {
      o <- order(v); cw <- cumsum(w[o])
      c(v[o][which(cw >= 0.025)[1]], v[o][which(cw >= 0.975)[1]])
    })
  }
  list(lower = q[1, ], upper = q[2, ], ess = 1 / sum(w^2))
}

one_trial <- function(sys, i, lib) {
  set.seed(1000 + i)
  p <- length(sys$lower)
  truth <- unlist(lhs(1, sys$lower + sys$inner[1] * (sys$upper - sys$lower),
                      sys$lower + sys$inner[2] * (sys$upper - sys$lower), sys$names))
  # the folded parameter away from the fold, where both modes are distinct
  if (isTRUE(sys$mirror)) truth[1] <- 0.5 + runif(1, 0.15, 0.35)
  y <- sys$sim(matrix(truth, 1))[1, ] + rnorm(ncol(lib$y), sd = sys$sd)
  field <- field_data(matrix(y, 1), t = lib$t)
  ref <- reference_posterior(sys, y, truth)
  t0 <- proc.time()[["elapsed"]]
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 1000, burn_in = 200, seed = i))
  plain <- resolution_limited(fit)
  warned_fit <- any(plain$limited)
  warned <- FALSE
  # the simulator's own time, to state refine()'s time outside it per run
  sim_seconds <- 0
  timed_sim <- function(theta) {
    t1 <- proc.time()[["elapsed"]]
    on.exit(sim_seconds <<- sim_seconds + proc.time()[["elapsed"]] - t1)
    sys$sim(theta)
  }
  r <- withCallingHandlers(
    suppressMessages(refine(fit, timed_sim, max_runs = max_runs, seed = i)),
    griddy_warning_resolution = function(w) {
      warned <<- TRUE
      message("trial ", i, ": ", conditionMessage(w))
      invokeRestart("muffleWarning")
    })
  secs <- proc.time()[["elapsed"]] - t0
  tab <- resolution_limited(r)
  # the posterior mass on the mirror mode (th1 < 0.5) of a bimodal system
  mirror_mass <- if (isTRUE(sys$mirror)) mean(lib_theta(r$library)[[1]][r$draws$run] < 0.5) else NA
  data.frame(system = system_name, trial = i, parameter = tab$parameter, truth = truth,
             lower = tab$lower, upper = tab$upper,
             covered = tab$lower <= truth & truth <= tab$upper,
             ref_lower = ref$lower, ref_upper = ref$upper,
             ref_covered = ref$lower <= truth & truth <= ref$upper, ref_ess = ref$ess,
             width_ratio = (tab$upper - tab$lower) / (ref$upper - ref$lower),
             effective_runs = tab$effective_runs, pareto_k = tab$pareto_k,
             mirror_mass = mirror_mass,
             plain_covered = plain$lower <= truth & truth <= plain$upper,
             plain_width_ratio = (plain$upper - plain$lower) / (ref$upper - ref$lower),
             warned_plain = warned_fit, warned = warned,
             runs_added = if (is.null(r$refinement)) 0L else r$refinement$runs_added,
             reason = if (is.null(r$refinement)) "resolved" else r$refinement$reason,
             seconds = secs, simulator_seconds = sim_seconds,
             machine = paste("load", paste(round(load_average(), 2), collapse = " ")))
}

load_average <- function() {
  if (file.exists("/proc/loadavg")) as.numeric(strsplit(readLines("/proc/loadavg"), " ")[[1]][1:3]) else NA
}

system_by_name <- function(name) {
  p <- as.integer(sub(".*-", "", name))
  if (startsWith(name, "bimodal")) return(bimodal_system(p))
  if (startsWith(name, "sharp")) return(utils::modifyList(smooth_system(p, n = 200), list(sd = 0.01)))
  smooth_system(p)
}

run_system <- function(sys, n_trials, n_lib = 2000L) {
  set.seed(2024)
  theta <- lhs(n_lib, sys$lower, sys$upper, sys$names)
  lib <- sim_library(theta, sys$sim(theta))
  do.call(rbind, lapply(seq_len(n_trials), function(i) {
    out <- one_trial(sys, i, lib)
    print(out[, c("trial", "parameter", "covered", "ref_covered", "width_ratio",
                  "effective_runs", "pareto_k", "warned", "runs_added", "reason",
                  "seconds")], digits = 3)
    out
  }))
}

if (sys.nframe() == 0L && n_trials > 0L) {
  sys <- system_by_name(system_name)
  res <- run_system(sys, n_trials)
  dir.create("bench/results", showWarnings = FALSE)
  data.table::fwrite(res, file.path("bench/results",
                                    paste0("many-parameters-", system_name, ".csv")))
  dt <- data.table::as.data.table(res)
  print(dt[, .(pairs = .N, plain_coverage = mean(plain_covered), coverage = mean(covered),
               ref_coverage = mean(ref_covered),
               median_width_ratio = median(width_ratio),
               median_width_ratio_ref_covered = median(width_ratio[ref_covered]),
               missed_unwarned = sum(!covered & !warned),
               missed_unwarned_ref_covered = sum(!covered & !warned & ref_covered),
               median_seconds = median(unique(data.table::data.table(trial, seconds))$seconds))])
  if (isTRUE(sys$mirror)) print(unique(dt[, .(trial, mirror_mass, warned)]))
  print(unique(dt[, .(trial, runs_added, reason, seconds, simulator_seconds,
                      ms_per_run_outside = 1000 * (seconds - simulator_seconds) / runs_added,
                      effective_runs, pareto_k)]))
  cat("load:", system("uptime", intern = TRUE), "\n")
}
