# What the user knows about the gap: gp_discrepancy(zero_at, flat_at).

# The simple machine (Brynjarsdottir and O'Hagan 2014): simulator theta x,
# reality 0.65 x / (1 + x / 20), 11 settings on [0.2, 4], noise sd 0.01.
simple_machine <- function(seed, step = 0.0025) {
  x <- data.frame(x = seq(0.2, 4, length.out = 11))
  theta <- data.frame(theta = seq(0.3, 1, by = step))
  set.seed(seed)
  y <- 0.65 * x$x / (1 + x$x / 20) + stats::rnorm(11, sd = 0.01)
  list(library = sim_library(theta, outer(theta$theta, x$x), x = x),
       field = field_data(matrix(y), x = x), theta = theta$theta)
}

# theta's 95% equal-tailed interval from the exact posterior over the runs
exact_interval <- function(sys, discrepancy) {
  ex <- posterior_exact(sys$library, sys$field, discrepancy = discrepancy, joint = FALSE)
  cp <- cumsum(ex$run)
  list(interval = sys$theta[c(which(cp >= 0.025)[1], which(cp >= 0.975)[1])],
       log_evidence = ex$log_evidence)
}

# The kernels of a discrepancy on a library (one per length-scale pair).
kernels_of <- function(library, discrepancy) {
  discrepancy_kernels(library, attr(discrepancy_points(discrepancy, library), "kernels"))
}

# The plain kernel between points given on the unit-scaled coordinates.
plain_kernel <- function(u, t, lx, lt) {
  d2 <- Reduce(`+`, lapply(seq_len(ncol(u)), function(j) outer(u[, j], u[, j], "-")^2))
  exp(-d2 / lx^2) * exp(-outer(t, t, "-")^2 / lt^2)
}

# The Gaussian conditional of delta over the first n points given L delta = 0.
brute_conditional <- function(K, L, n) {
  KL <- K %*% t(L)
  (K - KL %*% solve(L %*% KL, t(KL)))[seq_len(n), seq_len(n)]
}

test_that("the conditioned kernel is the Gaussian conditional on zeros and slopes", {
  # one x column and an output coordinate; the slope by central differences
  lib <- sim_library(data.frame(k = 1:2), matrix(1, 2, 12), x = data.frame(a = c(1, 2, 4, 5)),
                     t = c(0, 0.5, 1))
  disc <- gp_discrepancy(ratio = 1, length_x = 0.4, length_t = 0.7, orthogonal = FALSE,
                         zero_at = data.frame(a = 0, t = 0.5),
                         flat_at = data.frame(a = c(3, 0), t = c(1, 0.25)))
  K <- kernels_of(lib, disc)[[1]]
  h <- 1e-4
  u <- c(rep((c(1, 2, 4, 5) - 1) / 4, each = 3), -1 / 4, 0.5 + c(h, -h), -1 / 4 + c(h, -h))
  tt <- c(rep(c(0, 0.5, 1), 4), 0.5, 1, 1, 0.25, 0.25)
  L <- matrix(0, 3, length(u))
  L[1, 13] <- 1
  L[2, 14:15] <- c(1, -1) / (2 * h)
  L[3, 16:17] <- c(1, -1) / (2 * h)
  ref <- brute_conditional(plain_kernel(matrix(u), tt, 0.4, 0.7), L, 12)
  expect_equal(K, ref, tolerance = 1e-6)
  # two x columns: flat means the gradient over both is zero
  x <- expand.grid(p = c(0, 1, 2), q = c(0, 10))
  lib2 <- sim_library(data.frame(k = 1:2), matrix(1, 2, 6), x = x)
  disc2 <- gp_discrepancy(ratio = 1, length_x = 0.8, orthogonal = FALSE,
                          flat_at = data.frame(p = 1, q = 5))
  U <- rbind(cbind(x$p / 2, x$q / 10), cbind(0.5 + c(h, -h, 0, 0), 0.5 + c(0, 0, h, -h)))
  L2 <- matrix(0, 2, 10)
  L2[1, 7:8] <- c(1, -1) / (2 * h)
  L2[2, 9:10] <- c(1, -1) / (2 * h)
  ref2 <- brute_conditional(plain_kernel(U, rep(0, 10), 0.8, 1), L2, 6)
  expect_equal(kernels_of(lib2, disc2)[[1]], ref2, tolerance = 1e-6)
  # the same point twice adds nothing (the pseudo-inverse, no jitter)
  twice <- gp_discrepancy(ratio = 1, length_x = 0.8, orthogonal = FALSE,
                          flat_at = data.frame(p = c(1, 1), q = c(5, 5)))
  expect_equal(kernels_of(lib2, twice)[[1]], ref2, tolerance = 1e-6)
})

test_that("an orthogonal discrepancy with knowledge projects the conditioned process", {
  toy <- load_decay_system(function(l, t) l * sin(pi * t), 0.1, n_grid = 9, n_t = 10,
                           truth = c(1.5, 0.5))
  known <- gp_discrepancy(ratio = c(0, 1), length_x = 1, length_t = 0.5, orthogonal = TRUE,
                          zero_at = data.frame(load = 1, t = 0))
  expect_true(known$orthogonal)
  expect_false(gp_discrepancy(zero_at = data.frame(load = 1, t = 0))$orthogonal)
  expect_true(gp_discrepancy()$orthogonal)
  problem <- local_problem(toy$library, toy$field,
                                 discrepancy = known)
  kernels <- attr(problem$setup$discrepancy, "kernels")
  G <- attr(kernels, "sensitivity")
  conditioned <- kernels
  attr(conditioned, "sensitivity") <- NULL
  K_star <- discrepancy_kernels(toy$library, conditioned)[[1]]
  expect_equal(discrepancy_kernels(toy$library, kernels)[[1]],
               sensitivity_projector(G)(K_star))
  expect_equal(K_star[1, ], rep(0, ncol(K_star)))  # load 1, t 0 is the first output
})

test_that("delta's posterior is 0 where it is known to be, and flat where it is known flat", {
  sys <- bump_sys(n_t = 11)
  fit <- suppressWarnings(
    calibrate(sys$library, sys$field, n_iter = 400, burn_in = 100, seed = 1,
              discrepancy = gp_discrepancy(orthogonal = FALSE,
                                           zero_at = data.frame(amp = 1, t = 0.5))),
    classes = c("griddy_warning_resolution", "griddy_warning_gap",
                "griddy_warning_convergence"))
  post <- discrepancy_posterior(fit, ndraws = 50, seed = 1)
  at <- which(post$amp == 1 & abs(post$t - 0.5) < 1e-12)
  expect_lt(abs(post$mean[at]), 1e-8)
  expect_lt(post$sd[at], 1e-6)
  # the bump (0.4 at amp 3) is still seen: the largest mean is 0.11 with the
  # lengths up to 1, 0.10 with the length 3 that knowledge adds (issue 34)
  expect_gt(max(abs(post$mean)), 0.05)
  # with noise groups, every group's discrepancy is conditioned on the knowledge
  grouped <- suppressWarnings(
    calibrate(sys$library, sys$field, n_iter = 400, burn_in = 100, seed = 1, noise_groups = "x",
              discrepancy = gp_discrepancy(orthogonal = FALSE,
                                           zero_at = data.frame(amp = 1, t = 0.5))),
    classes = c("griddy_warning_resolution", "griddy_warning_gap",
                "griddy_warning_convergence"))
  post_g <- discrepancy_posterior(grouped, ndraws = 50, seed = 1)
  expect_lt(abs(post_g$mean[at]), 1e-8)
  expect_gt(max(abs(post_g$mean)), 0.01)  # not zero everywhere
  # flat: every conditioned covariance, so every posterior mean (a
  # combination of them), has zero slope over x at the flat setting
  lib <- sys$library
  disc <- gp_discrepancy(orthogonal = FALSE, flat_at = data.frame(amp = 2.5, t = 0.3))
  know <- knowledge_observations(lib, NULL, disc$flat_at)
  h <- 1e-5
  probe <- cell_observations(lib)
  probe$u <- rbind(probe$u, matrix(0.75 + c(h, -h)))
  probe$t <- c(probe$t, 0.3, 0.3)
  probe$d <- c(probe$d, 0L, 0L)
  K <- knowledge_cov(probe, probe, 0.3, 0.3)
  K_star <- condition_kernel(K, probe, know, 0.3, 0.3)
  n <- length(probe$d)
  slope <- (K_star[n - 1, ] - K_star[n, ]) / (2 * h)
  expect_lt(max(abs(slope)), 1e-4)
  expect_gt(max(abs((K[n - 1, ] - K[n, ]) / (2 * h))), 0.5)  # not flat without it
})

test_that("the simple machine: told delta(0) = 0 and delta'(0) = 0, theta's interval holds 0.65", {
  for (seed in 1:3) {
    sys <- simple_machine(seed)
    told <- exact_interval(sys, gp_discrepancy(zero_at = data.frame(x = 0),
                                               flat_at = data.frame(x = 0)))
    untold <- exact_interval(sys, gp_discrepancy())
    expect_true(told$interval[1] <= 0.65 && 0.65 <= told$interval[2])
    expect_false(untold$interval[1] <= 0.65 && 0.65 <= untold$interval[2])
    # the library resolves the interval: at least 20 runs across it
    expect_gt(diff(told$interval) / 0.0025, 20)
  }
})

test_that("wrong knowledge costs evidence against the fit without it", {
  sys <- simple_machine(1)
  # delta(1) = 0.031 and delta(4) = 0.43: no theta makes both zero
  wrong <- exact_interval(sys, gp_discrepancy(zero_at = data.frame(x = c(1, 4))))
  plain <- exact_interval(sys, gp_discrepancy(orthogonal = FALSE))
  default <- exact_interval(sys, gp_discrepancy())
  right <- exact_interval(sys, gp_discrepancy(zero_at = data.frame(x = 0),
                                              flat_at = data.frame(x = 0)))
  expect_lt(wrong$log_evidence, plain$log_evidence - 3)
  expect_lt(wrong$log_evidence, default$log_evidence - 3)
  expect_gt(right$log_evidence, plain$log_evidence)
})

test_that("gp_discrepancy() checks the knowledge, and calibrate() checks it against the library", {
  expect_error(gp_discrepancy(zero_at = list(x = 0)), class = "griddy_error_input")
  expect_error(gp_discrepancy(zero_at = data.frame(x = numeric(0))), class = "griddy_error_input")
  expect_error(gp_discrepancy(flat_at = data.frame(x = NA_real_)), class = "griddy_error_input")
  expect_error(gp_discrepancy(flat_at = data.frame(x = Inf)), class = "griddy_error_input")
  expect_error(gp_discrepancy(zero_at = data.frame(x = "a")), class = "griddy_error_input")
  sys <- simple_machine(1, step = 0.05)
  expect_error(posterior_exact(sys$library, sys$field,
                               discrepancy = gp_discrepancy(zero_at = data.frame(z = 0))),
               class = "griddy_error_input")
  expect_error(posterior_exact(sys$library, sys$field,
                               discrepancy = gp_discrepancy(zero_at = data.frame(x = 0, z = 0))),
               class = "griddy_error_input")
  bump <- bump_sys(n_t = 5)
  expect_error(calibrate(bump$library, bump$field, n_iter = 50, burn_in = 10,
                         discrepancy = gp_discrepancy(zero_at = data.frame(amp = 1))),
               class = "griddy_error_input")
  expect_snapshot(print(gp_discrepancy(zero_at = data.frame(x = 0), flat_at = data.frame(x = 0))))
})
