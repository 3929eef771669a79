# Shared by the bench/*.R scripts: timing, peak memory, machine load, the
# thesis's three-parameter test library and the plain-R Appendix A loop.

time_it <- function(expr) {
  gc()
  t0 <- proc.time()[["elapsed"]]
  force(expr)
  proc.time()[["elapsed"]] - t0
}

# Peak resident memory of this R process so far, in MB (Linux).
peak_mb <- function() {
  s <- readLines("/proc/self/status")
  as.numeric(sub("[^0-9]*([0-9]+).*", "\\1", grep("^VmHWM", s, value = TRUE))) / 1024
}

# Current resident memory in MB, and a reset of the peak (Linux >= 4.0), so
# that a later peak_mb() measures what came after.
rss_mb <- function() {
  s <- readLines("/proc/self/status")
  as.numeric(sub("[^0-9]*([0-9]+).*", "\\1", grep("^VmRSS", s, value = TRUE))) / 1024
}
reset_peak <- function() {
  invisible(try(writeLines("5", "/proc/self/clear_refs"), silent = TRUE))
}

machine_note <- function() {
  paste0(R.version.string, "; ", parallel::detectCores(), " cores; load average ",
         trimws(sub(".*load average: ", "", system("uptime", intern = TRUE))))
}

# A smooth three-parameter response at `n_points` locations: stands in for the
# piston simulator (the sampler's cost does not depend on what made the runs).
thesis_response <- function(h, locations) {
  outer(500 / sqrt(1 + h[, 1] / 1000), exp(-locations)) +
    outer(300 / sqrt(1 + h[, 2] / 1000), sin(3 * locations)) +
    outer(200 / sqrt(1 + h[, 3] / 1000), locations^2)
}

# Runs on a full grid of n_per_dim values per parameter (the thesis's ranges),
# or `n_runs` random runs.
thesis_theta <- function(n_per_dim = NULL, n_runs = NULL, seed = 1) {
  if (!is.null(n_per_dim)) {
    return(expand.grid(h1 = seq(13.85, 11984.70, length.out = n_per_dim),
                       h2 = seq(8.61, 11977.45, length.out = n_per_dim),
                       h3 = seq(35.33, 12002.49, length.out = n_per_dim)))
  }
  set.seed(seed)
  data.frame(h1 = runif(n_runs, 13.85, 11984.70), h2 = runif(n_runs, 8.61, 11977.45),
             h3 = runif(n_runs, 35.33, 12002.49))
}

thesis_field <- function(n_points, seed = 1) {
  locations <- seq(0, 1, length.out = n_points)
  set.seed(seed)
  drop(thesis_response(cbind(1000, 3000, 2000), locations)) + rnorm(n_points, sd = sqrt(0.4))
}

# The thesis's Appendix A loop in plain R, vectorised over runs with a loop
# over iterations: given the quadratic forms C (runs x grid points) and the
# log-determinants, draw theta | tau, rho by inverse CDF over all runs, then
# tau | theta, rho, then rho | theta, tau. Returns the kept runs.
thesis_plain_r <- function(C, logdet, n, n_iter, burn_in, a = 1e-9, b = 1e-9) {
  C <- as.matrix(C)
  G <- ncol(C)
  tau <- 1
  g <- 1L
  keep <- integer(n_iter - burn_in)
  for (it in seq_len(n_iter)) {
    lp <- -tau / 2 * C[, g]
    p <- exp(lp - max(lp))
    cdf <- cumsum(p) / sum(p)
    run <- which(cdf > runif(1))[1]
    tau <- rgamma(1, a + n / 2, b + C[run, g] / 2)
    if (G > 1L) {
      lw <- -logdet / 2 - tau / 2 * C[run, ]
      pw <- exp(lw - max(lw))
      g <- which(cumsum(pw) / sum(pw) > runif(1))[1]
    }
    if (it > burn_in) keep[it - burn_in] <- run
  }
  keep
}

# Plain-R quadratic forms with R_x = I and an AR(1) R_t per rho_t (thesis
# Appendix B), vectorised over runs: innovations of each x block, squared.
plain_quad_forms <- function(Y, y, n_x, t, rho_t) {
  n_t <- length(t)
  E <- matrix(y, nrow(Y), ncol(Y), byrow = TRUE) - Y
  s <- (t - min(t)) / (max(t) - min(t))
  out <- matrix(0, nrow(Y), length(rho_t))
  logdet <- numeric(length(rho_t))
  for (g in seq_along(rho_t)) {
    phi <- if (rho_t[g] == 0) rep(0, n_t - 1) else rho_t[g]^diff(s)
    for (k in seq_len(n_x)) {
      B <- E[, (k - 1) * n_t + seq_len(n_t)]
      W <- (B[, -1] - B[, -n_t] * rep(phi, each = nrow(B))) *
        rep(1 / sqrt(1 - phi^2), each = nrow(B))
      out[, g] <- out[, g] + B[, 1]^2 + rowSums(W^2)
    }
    logdet[g] <- n_x * sum(log1p(-phi^2))
  }
  list(C = out, logdet = logdet)
}
