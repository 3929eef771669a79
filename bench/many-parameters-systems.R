# The systems, reference posterior and trial of issue 24's many-parameter
# benchmarks, one definition each, sourced by bench/many-parameters.R and
# bench/many-parameters-scaling.R (run from the package root, griddy loaded).
#   smooth-p: 80 data points, y_i = sin(pi g_i . theta) + 0.5 exp(h_i . theta / 2)
#             with fixed random g_i, h_i; theta in [0, 1]^p; the last two of
#             p >= 6 parameters weakly identified (their g, h scaled by 0.15);
#             noise sd 0.05; the truth a Latin hypercube point of [0.15, 0.85]^p.
#   sharp-p:  smooth-p with 200 data points and noise sd 0.01 (a posterior
#             about 11 times narrower).
#   bimodal-p: smooth-p with th1 entering as 4 (th1 - 0.5)^2, so th1 and
#             1 - th1 fit equally: two modes of equal mass (truth th1 in
#             0.5 + [0.15, 0.35]).
# Reference posterior: importance sampling with the exact simulator, from a t
# proposal (df 5) at the least-squares fit with twice its Laplace covariance,
# 40,000 draws, uniform prior on the range, likelihood (SS)^(-n/2) as
# griddy's with a vague noise prior; for bimodal-p, mirrored in th1.

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

system_by_name <- function(name) {
  p <- as.integer(sub(".*-", "", name))
  if (startsWith(name, "bimodal")) return(bimodal_system(p))
  if (startsWith(name, "sharp")) return(utils::modifyList(smooth_system(p, n = 200), list(sd = 0.01)))
  smooth_system(p)
}

lhs <- function(n, lower, upper, names) {
  p <- length(lower)
  u <- matrix(vapply(seq_len(p), function(j) (sample.int(n) - runif(n)) / n, numeric(n)), n)
  stats::setNames(as.data.frame(sweep(sweep(u, 2, upper - lower, "*"), 2, lower, "+")), names)
}

# An n-run Latin hypercube library of the system (seed 2024: the 2,000-run
# library of bench/many-parameters.R)
lhs_library <- function(sys, n) {
  set.seed(2024)
  theta <- lhs(n, sys$lower, sys$upper, sys$names)
  sim_library(theta, sys$sim(theta))
}

# importance sampling reference: list(lower, upper, ess, mean, cov), the
# 95% intervals and the weighted draws' mean and covariance
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
  moments <- stats::cov.wt(draws, wt = w, method = "ML")
  list(lower = q[1, ], upper = q[2, ], ess = 1 / sum(w^2),
       mean = moments$center, cov = moments$cov)
}

# A trial's truth, field data and reference posterior (seed 1000 + i)
trial_data <- function(sys, i, lib) {
  set.seed(1000 + i)
  truth <- unlist(lhs(1, sys$lower + sys$inner[1] * (sys$upper - sys$lower),
                      sys$lower + sys$inner[2] * (sys$upper - sys$lower), sys$names))
  # the folded parameter away from the fold, where both modes are distinct
  if (isTRUE(sys$mirror)) truth[1] <- 0.5 + runif(1, 0.15, 0.35)
  y <- sys$sim(matrix(truth, 1))[1, ] + rnorm(ncol(lib$y), sd = sys$sd)
  field <- field_data(matrix(y, 1), t = lib$t)
  list(truth = truth, y = y, field = field, ref = reference_posterior(sys, y, truth))
}

# refine(fit, simulator) timed: list(fit, warned (a resolution warning),
# seconds (refine() alone), simulator_seconds (the simulator's share))
refine_timed <- function(fit, sys, max_runs, seed, label = seed) {
  warned <- FALSE
  sim_seconds <- 0
  timed_sim <- function(theta) {
    t1 <- proc.time()[["elapsed"]]
    on.exit(sim_seconds <<- sim_seconds + proc.time()[["elapsed"]] - t1)
    sys$sim(theta)
  }
  t0 <- proc.time()[["elapsed"]]
  r <- withCallingHandlers(
    suppressMessages(refine(fit, timed_sim, max_runs = max_runs, seed = seed)),
    griddy_warning_resolution = function(w) {
      warned <<- TRUE
      message("trial ", label, ": ", conditionMessage(w))
      invokeRestart("muffleWarning")
    })
  list(fit = r, warned = warned, seconds = proc.time()[["elapsed"]] - t0,
       simulator_seconds = sim_seconds)
}

# bench/many-parameters.R's trial: a plain fit on `lib`, then refine(fit,
# simulator, max_runs); one row per parameter. `seconds` is calibrate()
# plus refine(), `simulator_seconds` the simulator's share, `plain_*` the
# plain fit.
one_trial <- function(sys, i, lib, max_runs, system_name) {
  d <- trial_data(sys, i, lib)
  truth <- d$truth
  ref <- d$ref
  t0 <- proc.time()[["elapsed"]]
  fit <- suppressWarnings(calibrate(lib, d$field, n_iter = 1000, burn_in = 200, seed = i))
  plain <- resolution_limited(fit)
  warned_fit <- any(plain$limited)
  rt <- refine_timed(fit, sys, max_runs, seed = i)
  r <- rt$fit
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
             warned_plain = warned_fit, warned = rt$warned,
             runs_added = if (is.null(r$refinement)) 0L else r$refinement$runs_added,
             reason = if (is.null(r$refinement)) "resolved" else r$refinement$reason,
             seconds = secs, simulator_seconds = rt$simulator_seconds,
             machine = paste("load", paste(round(load_average(), 2), collapse = " ")))
}

load_average <- function() {
  if (file.exists("/proc/loadavg")) as.numeric(strsplit(readLines("/proc/loadavg"), " ")[[1]][1:3]) else NA
}
