# A system with a known additive gap: a 2-parameter library on a 9 x 9 grid
# over 3 loads x 10 outputs, field data from a run plus a smooth bump.
gap_toy <- function(bump = 0, sd = 0.05, seed = 3, reps = 1) {
  load_decay_system(function(l, t) l * sin(pi * t), bump, n_grid = 9, n_t = 10,
                    truth = c(1.5, 0.5), sd = sd, seed = seed, reps = reps)
}

test_that("gp_discrepancy() validates its grids", {
  expect_s3_class(gp_discrepancy(), "griddy_discrepancy")
  expect_error(gp_discrepancy(ratio = -1), class = "griddy_error_input")
  expect_error(gp_discrepancy(length_x = 0), class = "griddy_error_input")
  expect_error(gp_discrepancy(prior_none = 1), class = "griddy_error_input")
  expect_error(calibrate(gap_toy()$library, gap_toy()$field, discrepancy = list()),
               class = "griddy_error_input")
  expect_snapshot(print(gp_discrepancy(ratio = c(0, 1, 10), length_x = 1, length_t = 0.5)))
})

test_that("the discrepancy's points and prior: ratio 0 once, the rest equal", {
  lib <- gap_toy()$library
  pts <- discrepancy_points(gp_discrepancy(ratio = c(0, 1, 10), length_x = c(0.5, 1),
                                           length_t = 0.3, prior_none = 0.4), lib)
  expect_equal(nrow(pts), 1 + 2 * 2)
  expect_equal(sum(exp(pts$log_prior)), 1)
  expect_equal(exp(pts$log_prior[pts$ratio == 0]), 0.4)
  expect_true(all(is.na(pts$length_x[pts$ratio == 0])))
  only_none <- discrepancy_points(gp_discrepancy(ratio = 0), lib)
  expect_equal(exp(only_none$log_prior), 1)
})

# C and log|Sigma| by dense algebra, Sigma = S R S + lambda K over the
# observed points, for one run and one grid point.
brute_force_point <- function(problem, run, g) {
  setup <- problem$setup
  lib <- problem$library
  obs <- setup$dense$obs
  disc <- setup$discrepancy[setup$gd[g], ]
  t <- lib_t(lib)
  R_x <- crossprod(setup$Rx_chol[, , setup$gx[g]])
  R <- kronecker(R_x, corr_t(t, setup$rho_t[setup$gt[g]]))[obs, obs]
  s <- if (is.null(setup$dense$scale)) rep(1, length(obs)) else 1 / setup$dense$scale
  Sigma <- R * outer(s, s)
  if (disc$ratio > 0) {
    K <- discrepancy_kernels(lib, attr(setup$discrepancy, "kernels"))[[disc$kernel]]
    Sigma <- Sigma + disc$ratio * K[obs, obs]
  }
  r <- (problem$y_field - lib_outputs(lib, run)[1, ])[obs]
  list(C = sum(r * solve(Sigma, r)) + sum(setup$pure_ss),
       logdet = as.numeric(determinant(Sigma)$modulus))
}

test_that("the misfit table with a discrepancy is the dense algebra's", {
  toy <- gap_toy(bump = 0.1)
  problem <- local_problem(toy$library, toy$field, rho_t = c(0, 0.5),
                                 discrepancy = gp_discrepancy(ratio = c(0, 0.5, 20),
                                                                       length_x = c(0.3, 1),
                                                                       length_t = 0.2))
  expect_equal(ncol(problem$C), 2 * (1 + 2 * 2))
  expect_named(problem$grid, c("rho_x_load", "rho_t", "delta_ratio", "delta_length_x",
                               "delta_length_t"))
  for (g in c(1, 2, 4, 7, 10)) {
    bf <- brute_force_point(problem, 17, g)
    expect_equal(problem$C[17, g], bf$C, tolerance = 1e-10)
    # logdet holds log|Sigma| up to the constant of the replicates (none here)
    expect_equal(problem$setup$logdet[g], bf$logdet, tolerance = 1e-10)
  }
})

test_that("with replicates and missing cells, the dense algebra still holds", {
  toy <- gap_toy(bump = 0.1, reps = 2)
  y <- toy$field$y
  y[2, 3] <- NA
  field <- field_data(y, x = toy$field$x, t = toy$field$t)
  problem <- local_problem(toy$library, field,
                                 discrepancy = gp_discrepancy(ratio = c(0, 3), length_x = 0.5,
                                                              length_t = 0.5))
  for (g in 1:2) {
    bf <- brute_force_point(problem, 5, g)
    expect_equal(problem$C[5, g], bf$C, tolerance = 1e-10)
  }
  # the pure error is the same at every grid point: only the cell means' part moves
  expect_gt(problem$setup$pure_ss, 0)
})

test_that("ratio 0 alone reproduces the fit without a discrepancy", {
  toy <- gap_toy()
  p0 <- posterior_exact(toy$library, toy$field, rho_t = c(0, 0.4))
  p1 <- posterior_exact(toy$library, toy$field, rho_t = c(0, 0.4),
                        discrepancy = gp_discrepancy(ratio = 0))
  expect_equal(p1$run, p0$run, tolerance = 1e-10)
  expect_equal(p1$log_evidence, p0$log_evidence, tolerance = 1e-10)
})

test_that("the grid table and the draws carry the discrepancy's columns", {
  toy <- gap_toy(bump = 0.2)
  fit <- suppressWarnings(calibrate(toy$library, toy$field, n_iter = 400, burn_in = 100,
                                    seed = 1, discrepancy = gp_discrepancy(ratio = c(0, 1, 100))))
  expect_true(all(c("delta_ratio", "delta_length_x", "delta_length_t") %in% names(fit$grid)))
  d <- as.data.frame(fit)
  expect_true("delta_ratio" %in% names(d))
  s <- summary(fit)
  expect_true("delta_ratio" %in% s$parameter)
  expect_false(any(c("delta_length_x", "delta_length_t") %in% s$parameter))
})

test_that("noise groups: the discrepancy acts within each group", {
  toy <- gap_toy(bump = 0.1)
  groups <- rep(c("early", "late"), each = 5)
  problem <- local_problem(toy$library, toy$field,
                                 noise_groups = groups,
                                 discrepancy = gp_discrepancy(ratio = c(0, 2), length_x = 1,
                                                              length_t = 1))
  g <- 2
  point <- grid_point(problem$setup, g)
  K <- discrepancy_kernels(toy$library, attr(problem$setup$discrepancy, "kernels"))[[1]]
  idx <- which(rep(groups, 3) == "late")
  Sigma <- diag(length(idx)) + 2 * K[idx, idx]
  expect_equal(tcrossprod(point$dense$A[["late"]]), solve(Sigma), tolerance = 1e-10)
})

test_that("every backend gives the same evidence with a discrepancy: HDF5 as in memory", {
  skip_if_not_installed("hdf5r")
  toy <- gap_toy(bump = 0.1)
  disc <- gp_discrepancy(ratio = c(0, 1, 30), length_x = 1, length_t = c(0.3, 1))
  file <- withr::local_tempfile(fileext = ".h5")
  write_library(toy$library, file)
  h5 <- hdf5_library(file)
  in_memory <- posterior_exact(toy$library, toy$field, discrepancy = disc)
  on_disk <- posterior_exact(h5, toy$field, discrepancy = disc)
  expect_equal(on_disk$run, in_memory$run, tolerance = 1e-12)
  expect_equal(on_disk$log_evidence, in_memory$log_evidence, tolerance = 1e-12)
})

test_that("an emulated library's error and a discrepancy enter together", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 400)
  field <- emulated_toy_field()
  disc <- gp_discrepancy(ratio = c(0, 1, 30), length_x = 1, length_t = 1)
  exact <- suppressWarnings(posterior_exact(lib, field, discrepancy = disc))
  expect_equal(sum(exact$run), 1)
  expect_true(is.finite(discrepancy_evidence(exact)$log_bayes_factor))
  # the ratio-0 points are the model without a discrepancy, emulation error included
  plain <- suppressWarnings(posterior_exact(lib, field))
  none <- suppressWarnings(posterior_exact(lib, field, discrepancy = gp_discrepancy(ratio = 0)))
  expect_equal(none$run, plain$run, tolerance = 1e-8)
})

test_that("refine() keeps the discrepancy in every round", {
  skip_if_not_installed("RobustGaSP")
  toy <- gap_toy(bump = 0.1)
  sim <- function(theta) {
    t <- lib_t(toy$library)
    t(mapply(function(a, b) unlist(lapply(c(1, 2, 3), function(l) a * l * exp(-b * t))),
             theta$a, theta$b))
  }
  for (scaled in c(FALSE, TRUE)) {
    disc <- gp_discrepancy(ratio = c(0, 1, 30), length_x = 1, length_t = 1, scaled = scaled)
    fit <- suppressWarnings(calibrate(toy$library, toy$field, n_iter = 300, burn_in = 100,
                                      seed = 1, discrepancy = disc))
    ref <- suppressWarnings(refine(fit, sim, max_runs = 200, runs_per_round = 100, seed = 1))
    expect_identical(names(ref$grid), names(fit$grid))
    expect_equal(nrow(ref$grid), nrow(fit$grid))
    expect_true(is.finite(discrepancy_evidence(ref)$log_bayes_factor))
  }
})

test_that("an orthogonal discrepancy cannot imitate a change of theta", {
  toy <- gap_toy(bump = 0.1)
  problem <- local_problem(toy$library, toy$field,
                                 discrepancy = gp_discrepancy(ratio = c(0, 1), length_x = 1,
                                                              length_t = 0.5))
  kernels <- attr(problem$setup$discrepancy, "kernels")
  G <- attr(kernels, "sensitivity")
  expect_equal(dim(G), c(30L, 2L))
  K <- discrepancy_kernels(toy$library, kernels)[[1]]
  expect_lt(max(abs(K %*% G)), 1e-8 * max(abs(K)) * max(abs(G)))
  expect_equal(K, t(K))
  # the slopes are those of the outputs near the best run: a a*l*exp(-b t) library
  best <- best_fitting_run(toy$library, problem$y_field, NULL)
  expect_equal(best, which.min(rowSums(sweep(lib_outputs(toy$library), 2, problem$y_field)^2)))
  plain <- local_problem(toy$library, toy$field,
                               discrepancy = gp_discrepancy(ratio = c(0, 1), length_x = 1,
                                                            length_t = 0.5, orthogonal = FALSE))
  expect_null(attr(attr(plain$setup$discrepancy, "kernels"), "sensitivity"))
})

test_that("a library of one output calibrates: its sensitivity is a 1 x 1 slope", {
  # lm.fit() drops a one-column response to a vector: the gap screen's
  # orthogonal discrepancy failed with "incorrect number of dimensions"
  k <- seq(0.5, 1.5, length.out = 11)
  lib <- sim_library(data.frame(k = k), matrix(2 * k, ncol = 1))
  G <- discrepancy_sensitivity(lib, 2.04, NULL)
  expect_equal(G, matrix(2 * diff(range(k))), tolerance = 1e-10)
  fit <- suppressWarnings(calibrate(lib, field_data(2.04), n_iter = 200, burn_in = 50, seed = 1),
                          classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
  expect_s3_class(fit, "griddy_fit")
  # one output cannot tell a gap from noise: the screen finds nothing to warn of
  expect_false(screen_shows_gap(fit))
  fit_d <- suppressWarnings(calibrate(lib, field_data(2.04), n_iter = 200, burn_in = 50, seed = 1,
                                      discrepancy = gp_discrepancy()),
                            classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
  expect_true(is.finite(discrepancy_evidence(fit_d)$log_bayes_factor))
  # diagnose_gap() refits with a discrepancy the same way
  gap <- diagnose_gap(fit, seed = 1)
  expect_true(is.finite(gap$evidence$log_bayes_factor))
})

test_that("a scaled discrepancy (S-GaSP) has Gu and Wang's kernel, one per ratio", {
  toy <- gap_toy(bump = 0.1)
  y <- toy$field$y
  y[2, 3:4] <- NA  # the scaled kernel conditions on the observed points only
  field <- field_data(y, x = toy$field$x, t = toy$field$t)
  disc <- gp_discrepancy(ratio = c(0, 1, 30), length_x = 1, length_t = c(0.3, 0.6),
                         orthogonal = FALSE, scaled = TRUE)
  problem <- local_problem(toy$library, field, discrepancy = disc)
  points <- problem$setup$discrepancy
  kernels <- attr(points, "kernels")
  expect_equal(nrow(kernels), 4L)  # 2 ratios x 2 lengths: a kernel per point
  expect_equal(points$kernel[points$ratio > 0], 1:4)
  obs <- which(!is.na(problem$y_field))
  expect_equal(attr(kernels, "observed"), obs)
  plain <- discrepancy_kernels(toy$library, kernels[c("length_x", "length_t")])
  scaled <- discrepancy_kernels(toy$library, kernels)
  for (k in seq_len(nrow(kernels))) {
    # RobustCalibration's default lambda_z = sqrt(n |1 / l| / eta), eta = 1 / ratio
    lambda_z <- sqrt(length(obs) * sqrt(1 / kernels$length_x[k]^2 + 1 / kernels$length_t[k]^2) *
                       kernels$ratio[k])
    K <- plain[[k]][obs, obs]
    # the Woodbury form of K - K (K + n / lambda_z I)^-1 K
    expected <- solve(solve(K + diag(1e-10, length(obs))) + lambda_z / length(obs) * diag(length(obs)))
    expect_equal(scaled[[k]][obs, obs], expected, tolerance = 1e-5)
    # scaling only shrinks: K - K_z is positive semi-definite
    expect_gt(min(eigen(plain[[k]] - scaled[[k]], symmetric = TRUE)$values), -1e-8)
  }
  # and the engine uses each point's own kernel
  for (g in c(2, 4, 5)) {
    bf <- brute_force_point(problem, 11, g)
    expect_equal(problem$C[11, g], bf$C, tolerance = 1e-10)
    expect_equal(problem$setup$logdet[g], bf$logdet, tolerance = 1e-10)
  }
})

test_that("a scaled discrepancy grows like the square root of its ratio", {
  K <- exp(-outer(1:20 / 20, 1:20 / 20, "-")^2 / 0.3^2)
  size <- function(ratio) {
    ratio * sum(diag(scaled_kernel(K, 1:20, scaled_lambda_z(ratio, 20, 0.3))))
  }
  # a plain GaSP's mean square grows like the ratio, 100 times for 1e2 -> 1e4;
  # a scaled one's like its square root, 10 times (13.5 here: its smallest
  # components are not yet scaled)
  expect_lt(size(1e4) / size(1e2), 25)
  expect_gt(size(1e4) / size(1e2), 5)
})

test_that("a scaled discrepancy runs through calibrate(), its evidence and posterior", {
  toy <- gap_toy(bump = 0.1)
  expect_error(gp_discrepancy(scaled = NA), class = "griddy_error_input")
  expect_output(print(gp_discrepancy(scaled = TRUE)), "S-GaSP")
  disc <- gp_discrepancy(ratio = c(0, 1, 30), length_x = 1, length_t = 0.5, scaled = TRUE)
  fit <- suppressWarnings(calibrate(toy$library, toy$field, n_iter = 400, burn_in = 100,
                                    seed = 1, discrepancy = disc))
  expect_true(is.finite(discrepancy_evidence(fit)$log_bayes_factor))
  expect_true(all(c("delta_ratio", "delta_length_t") %in% names(fit$grid)))
  post <- discrepancy_posterior(fit)
  expect_true(all(is.finite(post$mean)))
})

test_that("gp_discrepancy() refuses length scales whose squares underflow or overflow (issue 32)", {
  # before: accepted, then "infinite or missing values" deep in the fit
  expect_error(gp_discrepancy(length_t = 1e-300), "length_t.*1e-300",
               class = "griddy_error_input")
  expect_error(gp_discrepancy(length_x = c(0.3, 1e-160)), "1e-160",
               class = "griddy_error_input")
  expect_error(gp_discrepancy(length_t = 1e200), class = "griddy_error_input")
  expect_error(gp_discrepancy(length_t = Inf), class = "griddy_error_input")
  # small but ordinary length scales stay: a kernel near the identity
  expect_s3_class(gp_discrepancy(length_t = 1e-100), "griddy_discrepancy")
  toy <- gap_toy()
  exact <- posterior_exact(toy$library, toy$field,
                           discrepancy = gp_discrepancy(ratio = c(0, 1), length_x = 1e-100,
                                                        length_t = 1e-100))
  expect_true(is.finite(exact$log_evidence))
})

test_that("with zero_at or flat_at the default length_x grid reaches 3, without it 1 (issue 34)", {
  expect_equal(gp_discrepancy()$length_x, c(0.1, 0.3, 1))
  expect_equal(gp_discrepancy(orthogonal = FALSE)$length_x, c(0.1, 0.3, 1))
  expect_equal(gp_discrepancy(zero_at = data.frame(x = 0))$length_x, c(0.1, 0.3, 1, 3))
  expect_equal(gp_discrepancy(flat_at = data.frame(x = 0), orthogonal = TRUE)$length_x,
               c(0.1, 0.3, 1, 3))
  # a grid the user gives is kept, with knowledge or without
  expect_equal(gp_discrepancy(zero_at = data.frame(x = 0), length_x = c(1, 0.5))$length_x,
               c(0.5, 1))
  expect_equal(gp_discrepancy()$length_t, c(0.1, 0.3, 1))
})

test_that("the simple machine's band at x = 6 holds reality with zero_at and flat_at (issue 34)", {
  # Brynjarsdottir and O'Hagan's simple machine, noise seed 1: with the old
  # grid (lengths up to 1) the process reverted to 0 beyond x = 4 and the
  # band for a new measurement at x = 6 missed reality's 0.65 * 36 / 26;
  # with 3 in the grid it holds it (9 of 10 seeds, bench/length-grid.R)
  x <- data.frame(x = seq(0.2, 4, length.out = 11))
  theta <- data.frame(theta = seq(0.3, 1, by = 0.0025))
  lib <- sim_library(theta, outer(theta$theta, x$x), x = x)
  set.seed(1)
  field <- field_data(matrix(0.65 * x$x / (1 + x$x / 20) + stats::rnorm(11, sd = 0.01)), x = x)
  known <- function(...) {
    gp_discrepancy(zero_at = data.frame(x = 0), flat_at = data.frame(x = 0), ...)
  }
  band <- function(disc) {
    fit <- suppressWarnings(calibrate(lib, field, discrepancy = disc, n_iter = 4000,
                                      burn_in = 500, seed = 1))
    predict(fit, newdata = data.frame(x = 6), seed = 1,
            simulator = function(theta, x) outer(theta$theta, x$x))
  }
  truth <- 0.65 * 6 / (1 + 6 / 20)
  now <- band(known())
  expect_true(now$pred_lower <= truth && truth <= now$pred_upper)
  before <- band(known(length_x = c(0.1, 0.3, 1)))
  expect_false(before$pred_lower <= truth && truth <= before$pred_upper)
})

test_that("scaled_rows() scales the varying parameters to [0, 1] as the matrix arithmetic does", {
  unit_scaled_theta <- function(theta) scaled_rows(theta_scale(theta), seq_len(NROW(theta)))
  set.seed(3)
  theta <- data.frame(a = runif(50, 2, 5), fixed = 1, b = sample(1:4, 50, TRUE))
  m <- as.matrix(theta)
  span <- apply(m, 2, function(v) diff(range(v)))
  ref <- sweep(sweep(m, 2, apply(m, 2, min)), 2, pmax(span, 1e-300), "/")[, span > 0]
  expect_identical(unit_scaled_theta(theta), ref)
  expect_identical(unit_scaled_theta(m), ref)
  expect_equal(ncol(unit_scaled_theta(data.frame(a = rep(1, 5)))), 0L)
})

test_that("discrepancy_sensitivity() finds the nearest runs as a search over every run does, ties included", {
  # the search runs over near_candidates_cpp()'s candidates only; on a grid
  # many runs tie, and nearest_runs()'s rounding breaks the ties
  full_search <- function(lib, best) {
    theta <- scaled_rows(theta_scale(lib_theta(lib)), seq_len(nrow(lib_theta(lib))))
    k <- max(4L * ncol(theta) + 2L, 12L)
    near <- nearest_runs(theta[best, , drop = FALSE], theta, k)$idx[1, ]
    X <- sweep(theta[near, , drop = FALSE], 2, theta[best, ])
    fit <- stats::lm.fit(cbind(1, X), lib_outputs(lib, near))
    t(matrix(fit$coefficients[-1, , drop = FALSE], ncol(X)))
  }
  th <- expand.grid(a = seq(0, 1, length.out = 12), b = seq(2, 3, length.out = 9),
                    c = c(1, 2, 4, 5, 7))
  lib <- sim_library(th, cbind(th$a * 2 + th$c, sin(th$a) + th$b^2, th$a * th$c))
  for (best in c(1L, 50L, 271L, nrow(th))) {
    expect_identical(discrepancy_sensitivity(lib, NULL, NULL, best), full_search(lib, best))
  }
  expect_identical(near_candidates_cpp(list(c(0, 1, 2, 3)), 3, 2L, 10L, 1e-9), 1:4)
  expect_identical(near_candidates_cpp(list(c(0, 1, 2, 3, 1)), 3, 2L, 2L, 1e-9), c(2L, 5L))
  expect_identical(near_candidates_cpp(list(c(0, 1, 2, 3, 1)), 3, 2L, 3L, 1e-9), c(1L, 2L, 3L, 5L))
})
