# Small libraries whose exact grid posterior posterior_exact() gives, for
# checking the sampler against it.

# One parameter, n_t outputs over t in [0, 1] at one x setting; field data from
# theta_true plus AR(1) noise with lag-one correlation `lag_cor`.
toy_ar1 <- function(n_runs = 500, n_t = 60, theta_true = 0.37, sd = 0.3, lag_cor = 0.8,
                    seed = 11) {
  t <- seq(0, 1, length.out = n_t)
  theta <- data.frame(theta = seq(0, 1, length.out = n_runs))
  sim <- function(th) sin(2 * pi * t + 3 * th) + th * t
  y <- t(vapply(theta$theta, sim, numeric(n_t)))
  set.seed(seed)
  e <- if (lag_cor == 0) stats::rnorm(n_t, sd = sd) else
    as.vector(stats::arima.sim(list(ar = lag_cor), n = n_t, sd = sd * sqrt(1 - lag_cor^2)))
  list(library = sim_library(theta, y, t = t), field = field_data(sim(theta_true) + e),
       truth = c(theta = theta_true))
}

# Two parameters on a grid, three x settings (two x columns), n_t outputs each.
toy_xt <- function(n_per_dim = 8, n_t = 12, sd = 1, seed = 5) {
  grid <- expand.grid(a = seq(1, 2, length.out = n_per_dim), b = seq(0, 1, length.out = n_per_dim))
  x <- data.frame(load = c(1, 2, 3), speed = c(10, 10, 20))
  t <- seq(0, 2, length.out = n_t)
  sim <- function(a, b, load, speed) a * load * exp(-b * t) + speed / 10 * cos(t)
  y <- t(mapply(function(a, b) {
    unlist(lapply(seq_len(nrow(x)), function(k) sim(a, b, x$load[k], x$speed[k])))
  }, grid$a, grid$b))
  set.seed(seed)
  field <- t(vapply(seq_len(nrow(x)), function(k) {
    sim(1.5, 0.4, x$load[k], x$speed[k]) + stats::rnorm(n_t, sd = sd)
  }, numeric(n_t)))
  list(library = sim_library(grid, y, x = x, t = t), field = field_data(field, x = x, t = t))
}

# Expected total-variation distance between the empirical frequencies of m
# independent draws from p and p itself (normal approximation of each cell):
# E|f_i - p_i| = sqrt(2 p_i (1 - p_i) / (pi m)).
expected_tv_iid <- function(p, m) {
  sum(sqrt(2 * p * (1 - p) / (pi * m))) / 2
}

tv_distance <- function(p, q) sum(abs(p - q)) / 2

# Parallel future workers load griddy from the library, not from the source
# tree: run those tests only when the installed griddy has this tree's code.
installed_griddy_is_current <- function(fun = "run_chain") {
  if (length(find.package("griddy", lib.loc = .libPaths(), quiet = TRUE)) == 0L) {
    return(FALSE)
  }
  out <- suppressWarnings(system2(
    file.path(R.home("bin"), "Rscript"),
    c("-e", shQuote(sprintf("cat(exists('%s', envir = asNamespace('griddy')))", fun))),
    stdout = TRUE, stderr = FALSE, env = paste0("R_LIBS=", paste(.libPaths(), collapse = ":"))))
  identical(out, "TRUE")
}

