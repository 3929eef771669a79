# A one-parameter model y = sin(k t) at 40 times, its coarse library (k in
# 1..4 by 0.5) and field data at k = 2.23: the truth lies between runs and
# the data pin k down far more finely than the library's spacing.
refine_sim <- function(theta) {
  t <- seq(0, 1, length.out = 40)
  t(vapply(theta$k, function(k) sin(k * t), numeric(40)))
}

refine_toy <- function(sd = 0.02, seed = 1, k = 2.23) {
  theta <- data.frame(k = seq(1, 4, by = 0.5))
  lib <- sim_library(theta, refine_sim(theta))
  set.seed(seed)
  field <- field_data(refine_sim(data.frame(k = k)) + stats::rnorm(40, sd = sd), t = lib$t)
  fit <- toy_fit(paste("refine_toy", sd, seed, k), {
    suppressWarnings(calibrate(lib, field, n_iter = 1500, burn_in = 500, seed = 1))
  })
  list(lib = lib, field = field, fit = fit, k = k)
}

# The toys' fits, calibrated once per test run (many files refine the same
# toy): calibrate() with a seed leaves R's stream as it found it, so the
# toy's own draws, made every time, leave it as an uncached toy would.
toy_fits <- new.env(parent = emptyenv())
toy_fit <- function(key, fit) {
  if (is.null(toy_fits[[key]])) toy_fits[[key]] <- fit
  toy_fits[[key]]
}

# The continuous posterior's 95% interval of k, from a dense library.
refine_toy_reference <- function(toy) {
  dense <- data.frame(k = seq(1, 4, length.out = 30001))
  lib <- sim_library(dense, refine_sim(dense))
  p <- posterior_exact(lib, toy$field)$run
  cdf <- cumsum(p)
  dense$k[c(which(cdf >= 0.025)[1], which(cdf >= 0.975)[1])]
}

# refine_sim() that records every theta it is given (in `seen`) and, at its
# `fail_at`-th call, stops with `fail` (a function signalling a condition);
# the first theta of that call stays broken: every later call with it fails
# too (so a failing chunk run again row by row loses that run only).
refine_sim_failing <- function(fail_at = Inf, fail = function() stop("the solver diverged")) {
  env <- new.env()
  env$calls <- 0L
  env$seen <- NULL
  env$broken <- numeric(0)
  env$sim <- function(theta) {
    env$calls <- env$calls + 1L
    if (env$calls == fail_at) env$broken <- theta$k[1]
    if (any(theta$k %in% env$broken)) fail()
    env$seen <- rbind(env$seen, theta)
    refine_sim(theta)
  }
  env
}

# A stand-in for the user's interrupt (Ctrl-C): the condition R signals.
signal_interrupt <- function() {
  signalCondition(structure(class = c("interrupt", "condition"),
                            list(message = "", call = NULL)))
  stop("an interrupt is not caught")
}

# y = X theta at 30 points, 4 parameters, theta in [0, 1]^4
linear4_sim <- function(theta) {
  x <- seq(0, 1, length.out = 30)
  X <- cbind(1, cos(pi * x), cos(2 * pi * x), cos(3 * pi * x))
  as.matrix(theta) %*% t(X)
}

# An n-run Latin hypercube over [0, 1]^4 (th1 to th4), from R's RNG.
lhs_theta4 <- function(n) {
  theta <- as.data.frame(vapply(1:4, function(j) (sample.int(n) - stats::runif(n)) / n,
                                numeric(n)))
  stats::setNames(theta, paste0("th", 1:4))
}

# A 500-run Latin hypercube library of linear4_sim() and a fit to data at
# (0.4, 0.55, 0.6, 0.45) with noise sd 0.02: the posterior is far narrower
# than the runs' spacing.
linear4_toy <- function() {
  set.seed(4)
  theta <- lhs_theta4(500)
  lib <- sim_library(theta, linear4_sim(theta))
  y <- linear4_sim(matrix(c(0.4, 0.55, 0.6, 0.45), 1)) + stats::rnorm(30, sd = 0.02)
  field <- field_data(y, t = lib$t)
  list(lib = lib, y = y, fit = toy_fit("linear4_toy", {
    suppressWarnings(calibrate(lib, field, n_iter = 500, burn_in = 100, seed = 1))
  }))
}

# A 1-parameter library too coarse to predict its own runs (outputs
# sin(k^2 t) on k = 1, 1.5, ..., 4) and its fit to data at k = 2.71: refine()
# without a simulator then predicts worse than the noise
# (test-refine-predict.R), and its misfit shows as a gap (test-gap-screen.R).
sharp_fit <- function() {
  sharp <- function(theta) {
    t <- seq(0, 1, length.out = 40)
    t(vapply(theta$k, function(k) sin(k^2 * t), numeric(40)))
  }
  theta <- data.frame(k = seq(1, 4, by = 0.5))
  lib <- sim_library(theta, sharp(theta))
  set.seed(3)
  field <- field_data(sharp(data.frame(k = 2.71)) + rnorm(40, sd = 0.01), t = lib$t)
  suppressWarnings(calibrate(lib, field, n_iter = 500, burn_in = 100, seed = 1))
}
