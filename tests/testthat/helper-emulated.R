# A smooth toy in the joint (x, theta) layout: y(x, k, c; t) =
# exp(-c t) sin(k t + x) at 10 times, a Latin hypercube of `n` runs over
# (x, k, c) jointly, so no two runs share an x setting.
emulated_sim <- function(x, theta, t = seq(0, 2, length.out = 10)) {
  exp(-outer(theta[, "c"], t)) * sin(outer(theta[, "k"], t) + x)
}

emulated_toy_design <- function(n = 40, seed = 1) {
  set.seed(seed)
  u <- vapply(1:3, function(j) (sample.int(n) - stats::runif(n)) / n, numeric(n))
  theta <- cbind(k = 1 + 2 * u[, 2], c = 0.1 + 0.4 * u[, 3])
  x <- u[, 1]
  y <- t(vapply(seq_len(n), function(i) emulated_sim(x[i], theta[i, , drop = FALSE]),
                numeric(10)))
  list(theta = theta, x = x, y = y, settings = data.frame(x = c(0.2, 0.5, 0.8)),
       t = seq(0, 2, length.out = 10))
}

# The toy's outputs at every wanted setting, in the library's layout.
emulated_truth <- function(theta, settings = c(0.2, 0.5, 0.8)) {
  do.call(cbind, lapply(settings, function(x) emulated_sim(x, theta)))
}

emulated_toy_library <- function(n = 40, n_runs = 2000, seed = 1) {
  d <- emulated_toy_design(n, seed)
  emulated_library(d$theta, d$y, x = data.frame(x = d$x), t = d$t, settings = d$settings,
                   n_runs = n_runs, seed = seed)
}

emulated_toy_field <- function(k = 2.1, c = 0.3, sd = 0.02, seed = 2) {
  set.seed(seed)
  y <- matrix(emulated_truth(cbind(k = k, c = c)), 3, 10, byrow = TRUE) +
    stats::rnorm(30, sd = sd)
  field_data(y, x = data.frame(x = c(0.2, 0.5, 0.8)), t = seq(0, 2, length.out = 10))
}
