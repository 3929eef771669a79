# A small system with a known gap: outputs a * load * sin(3t) over three loads;
# the effect "quadratic" adds s * load^2 * t^2 (changes shape across loads),
# the effect "scale" multiplies a by (1 + s) (a shift of theta imitates it).
# The library holds a = `a_grid`; the data are made at a = `a_true`.
# `missing` (cells in library order) are left unmeasured (NA); `rel_sd`, one
# per cell, is the field's relative sd (the noise sd is `sd * rel_sd`).
toy_gap <- function(s_true = 0, bump = 0, sd = 0.05, seed = 1, n_t = 30, rho_t = 0,
                    a_true = 1, a_grid = seq(0.5, 1.5, length.out = 41), missing = NULL,
                    rel_sd = NULL) {
  t <- seq(0, 1, length.out = n_t)
  x <- data.frame(load = c(1, 2, 3))
  sim <- function(a, s) unlist(lapply(x$load, function(l) a * l * sin(3 * t) + s * l^2 * t^2))
  base <- data.frame(a = a_grid)
  lib <- sim_library(base, t(vapply(base$a, sim, numeric(3 * n_t), s = 0)), x = x, t = t)
  g1 <- expand.grid(a = base$a, s = c(0, 0.1, 0.2, 0.3))
  quad <- sim_library(g1, t(mapply(sim, g1$a, g1$s)), x = x, t = t)
  g2 <- expand.grid(a = base$a, s = c(0, 0.1, 0.2))
  scale <- sim_library(g2, t(mapply(function(a, s) sim(a * (1 + s), 0), g2$a, g2$s)),
                       x = x, t = t)
  set.seed(seed)
  noise_sd <- sd * (if (is.null(rel_sd)) 1 else rel_sd)
  y <- sim(a_true, s_true) + stats::rnorm(3 * n_t, sd = noise_sd)
  # a localised discrepancy: a bump at the second load around t = 0.5
  y[n_t + seq_len(n_t)] <- y[n_t + seq_len(n_t)] + bump * exp(-((t - 0.5) / 0.05)^2)
  y[missing] <- NA
  field <- field_data(matrix(y, 3, byrow = TRUE), x = x, t = t,
                      sd = if (!is.null(rel_sd)) matrix(rel_sd, 3, byrow = TRUE))
  fit <- suppressWarnings(calibrate(lib, field, rho_t = rho_t, n_iter = 300, burn_in = 100,
                                    seed = 1))
  list(lib = lib, field = field, fit = fit, quad = quad, scale = scale, sim = sim,
       t = t, x = x)
}

# missing cells (a run of t at the first load, most of the second load's
# middle, one at the third) and an uneven relative sd, for toy_gap()
gap_missing <- c(3, 4, 5, 40:47, 70)
gap_rel_sd <- rep(c(1, 2, 0.5), each = 30) * (1 + 0.3 * sin(1:90))
