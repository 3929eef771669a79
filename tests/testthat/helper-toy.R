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


# A small library (8 runs of one parameter, 3 x settings x 5 outputs) and
# field data with some cells missing, for checking the likelihood over the
# observed points against dense algebra.
toy_missing <- function(missing = c(2, 7, 8, 13), seed = 3) {
  x <- data.frame(h = c(1, 2, 4))
  t <- seq(0, 1, length.out = 5)
  theta <- data.frame(k = 1:8)
  Y <- t(vapply(theta$k, function(k) rep(sin(t * k / 3), 3) * rep(x$h, each = 5), numeric(15)))
  set.seed(seed)
  y <- Y[4, ] + stats::rnorm(15, sd = 0.3)
  y[missing] <- NA
  list(library = sim_library(theta, Y, x = x, t = t), y = y, Y = Y, x = x, t = t,
       field = field_data(y, x = x, t = t))
}

# The log joint over (run, grid point) by dense algebra: for each noise group
# (labels `groups`, one per library output) the observed block of
# S (R_x (x) R_t) S, its inverse and determinant, and the Gamma-normal
# marginal likelihood; uniform priors.
brute_log_joint <- function(toy, grid, prior, groups = rep(1, 15), sd = rep(1, 15)) {
  obs <- which(!is.na(toy$y))
  lj <- matrix(0, nrow(toy$Y), nrow(grid))
  for (g in seq_len(nrow(grid))) {
    R <- kronecker(corr_x(toy$x, grid$rho_x_h[g]), corr_t(toy$t, grid$rho_t[g]))
    R <- diag(sd) %*% R %*% diag(sd)
    for (i in seq_len(nrow(toy$Y))) for (k in unique(groups)) {
      o <- intersect(obs, which(groups == k))
      n <- length(o)
      r <- (toy$y - toy$Y[i, ])[o]
      C <- drop(t(r) %*% solve(R[o, o], r))
      lj[i, g] <- lj[i, g] - 0.5 * as.numeric(determinant(R[o, o])$modulus) -
        (prior$shape + n / 2) * log(prior$rate + C / 2) + prior$shape * log(prior$rate) -
        lgamma(prior$shape) + lgamma(prior$shape + n / 2) - n / 2 * log(2 * pi)
    }
  }
  lj - log(nrow(toy$Y)) - log(nrow(grid))
}

# toy_missing()'s library with replicated field experiments: 3, 1 and 2 rows
# at its three x settings (6 x 5 measurements, two of them missing), with
# relative sd `sd` (a 6 x 5 matrix) or none.
toy_replicates <- function(sd = NULL, seed = 4) {
  toy <- toy_missing(integer(0))
  rows <- rep(1:3, c(3, 1, 2))
  set.seed(seed)
  truth <- matrix(toy$Y[4, ], 3, byrow = TRUE)[rows, ]
  y <- truth + stats::rnorm(30, sd = 0.3) * (if (is.null(sd)) 1 else sd)
  y[2, 3] <- NA
  y[6, 1] <- NA
  c(toy[c("library", "Y", "x", "t")],
    list(rows = rows, y_rep = y, sd = sd,
         field = field_data(y, x = toy$x[rows, , drop = FALSE], t = toy$t, sd = sd)))
}

# The log joint over runs (uniform prior, independent noise) from every
# individual measurement of toy_replicates(): in each noise group (labels
# `groups`, one per library output) the Gamma-normal marginal likelihood of
# its measurements.
brute_replicates <- function(toy, prior, groups = rep(1, 15)) {
  sd <- if (is.null(toy$sd)) 1 + 0 * toy$y_rep else toy$sd
  group <- matrix(groups, 3, byrow = TRUE)[toy$rows, ]
  vapply(seq_len(nrow(toy$Y)), function(i) {
    r <- toy$y_rep - matrix(toy$Y[i, ], 3, byrow = TRUE)[toy$rows, ]
    sum(vapply(unique(groups), function(k) {
      o <- !is.na(r) & group == k
      n <- sum(o)
      C <- sum((r[o] / sd[o])^2)
      prior$shape * log(prior$rate) - lgamma(prior$shape) + lgamma(prior$shape + n / 2) -
        n / 2 * log(2 * pi) - sum(log(sd[o])) - (prior$shape + n / 2) * log(prior$rate + C / 2)
    }, numeric(1)))
  }, numeric(1)) - log(nrow(toy$Y))
}

# Snapshot transform for printed objects that name temporary files or times:
# the session's temporary directory and elapsed seconds vary between runs.
scrub_print <- function(lines) {
  lines <- gsub(normalizePath(tempdir(), mustWork = FALSE), "<tempdir>", lines, fixed = TRUE)
  lines <- gsub(tempdir(), "<tempdir>", lines, fixed = TRUE)
  lines <- gsub("<tempdir>/[^ ]+", "<tempdir>/<file>", lines)
  lines <- gsub("(precompute|sampling|checks) [0-9.e-]+", "\\1 <t>", lines)
  gsub("[0-9]+(\\.[0-9]+)? s\\b", "<t> s", lines)
}
