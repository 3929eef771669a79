test_that("one truncation rule: the leading directions hold 99.99% of the second moment", {
  expect_identical(error_rank(c(1, 1e-3, 1e-5, 1e-7)), 2L)
  expect_identical(error_rank(c(1, 1, 1)), 3L)
  expect_identical(error_rank(rep(1, 80)), 50L)
  set.seed(1)
  E <- matrix(rnorm(200), 20) %*% diag(c(10, 1, 0.1, 0.01, 1e-3, rep(1e-6, 5)))
  err <- emulation_error_model(E, 1)
  d2 <- svd(E / sqrt(nrow(E)))$d^2
  expect_identical(ncol(err$U), error_rank(d2))
  expect_gte(sum(err$lambda) / sum(d2), error_energy)
})

test_that("the error model's leading directions are those of the full SVD, tall or wide", {
  set.seed(2)
  for (shape in list(c(600, 240), c(240, 600))) {
    decay <- 10^(-(seq_len(60) - 1) / 8)
    E <- matrix(rnorm(shape[1] * 60), shape[1]) %*%
      (decay * matrix(rnorm(60 * shape[2]), 60)) + 1e-9 * rnorm(prod(shape))
    s <- leading_svd(E, 80L)
    full <- svd(E, nu = 0L)
    m <- error_rank(full$d^2)
    expect_gt(m, 10L)
    # the kept values, and the directions up to sign: the same projections
    expect_equal(s$d[1:m], full$d[1:m], tolerance = 1e-10)
    V <- s$v[, 1:m] %*% (s$d[1:m]^2 * t(s$v[, 1:m]))
    W <- full$v[, 1:m] %*% (full$d[1:m]^2 * t(full$v[, 1:m]))
    expect_lt(max(abs(V - W)) / max(abs(W)), 1e-10)
    err <- emulation_error_model(E, 1)
    expect_identical(ncol(err$U), error_rank(full$d^2 / nrow(E)))
    expect_equal(err$lambda, full$d[1:m]^2 / nrow(E), tolerance = 1e-10)
  }
})

test_that("the error model is the Kronecker product of settings and outputs, as dense algebra", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 50)
  err <- lib$error
  gp <- lib$emulator
  V <- err$U %*% diag(err$lambda, length(err$lambda)) %*% t(err$U)
  pred <- design_gp_predict(gp, as.matrix(lib$theta))
  s <- colMeans(pred$var)
  s <- s / mean(s)
  K <- sqrt(s) * t(sqrt(s) * design_gp_setting_cor(gp))
  E <- standardised_loo(gp)
  Vt <- crossprod(E) / nrow(E)
  dense <- kronecker(K, Vt)
  expect_lt(norm(V - dense, "F") / norm(dense, "F"), 0.02)
  # the settings' errors are correlated, not independent
  expect_gt(K[1, 2] / sqrt(K[1, 1] * K[2, 2]), 0.1)
  field <- emulated_toy_field()
  y <- as.vector(t(field$y))
  setup <- correlation_setup(lib, list(x = 0), 0)
  got <- emulated_library_forms(lib, y, setup, 4e-4, kappa = 0.7)
  for (i in 1:3) {
    S <- diag(length(y)) + 0.7 * V / 4e-4
    r <- y - lib$y[i, ]
    expect_equal(got$C[i, 1], drop(t(r) %*% solve(S, r)), tolerance = 1e-8)
    expect_equal(got$extra_logdet[i, 1], as.numeric(determinant(S)$modulus),
                 tolerance = 1e-8)
  }
})

test_that("the misfit table and the leave-block pieces are one algebra", {
  toy <- refine_toy()
  refined <- refine(toy$fit, max_runs = 200, runs_per_round = 100, seed = 2)
  lib <- refined$library
  ctx <- gap_context(refined)
  point <- ctx$points[[1]]
  j <- lib_n_runs(lib$base) + 5L
  err <- run_emulation(run_errors(lib), j, ctx$obs)
  r <- refined$y_field - lib_outputs(lib, j)[1, ]
  wood <- emulated_inverse(ctx, point, r, err)
  S <- diag(length(r)) + tcrossprod(err$V)
  Si <- solve(S)
  expect_equal(wood$Q, drop(t(r) %*% Si %*% r), tolerance = 1e-10)
  expect_equal(wood$logdet, as.numeric(determinant(S)$modulus), tolerance = 1e-10)
  # the table's form of the same run
  C <- list(C = matrix(wood$Q), extra_logdet = matrix(wood$logdet))
  expect_equal(drop(fold_extra_logdet(C, refined$prior, ctx$n)), refined$C[j, 1],
               tolerance = 1e-8)
  W <- 11:20
  bs <- emulated_block(wood, block_precision(ctx, point, W, W, 1L), W)
  h <- Si %*% r
  expect_equal(bs$D, drop(t(h[W]) %*% solve(Si[W, W], h[W])), tolerance = 1e-10)
  expect_equal(bs$logdet_BB, as.numeric(determinant(Si[W, W])$modulus), tolerance = 1e-10)
})

test_that("with replicates, a predicted run's leave-block form keeps the pure error, as C", {
  # issue 33: its Q lacked the replicates' pure-error sum of squares that C and
  # the block statistic's degrees of freedom count, so the checks of predicted
  # runs saw too little noise and flagged blocks in data without a gap
  toy <- refine_toy()
  set.seed(4)
  y <- c(toy$field$y, toy$field$y + stats::rnorm(40, sd = 0.02))
  field <- field_data(data.frame(t = rep(toy$lib$t, 2), y = y))
  fit <- suppressWarnings(calibrate(toy$lib, field, n_iter = 300, burn_in = 100, seed = 1))
  refined <- suppressWarnings(refine(fit, max_runs = 200, runs_per_round = 100, seed = 2),
                              classes = "griddy_warning")
  ctx <- gap_context(refined)
  expect_gt(sum(ctx$setup$pure_ss), 0)
  lib <- refined$library
  j <- lib_n_runs(lib$base) + 5L
  err <- run_emulation(run_errors(lib), j, ctx$obs)
  r <- (refined$y_field - lib_outputs(lib, j)[1, ])[ctx$obs]
  wood <- emulated_inverse(ctx, ctx$points[[1]], r, err)
  C <- list(C = matrix(wood$Q), extra_logdet = matrix(wood$logdet))
  expect_equal(drop(fold_extra_logdet(C, refined$prior, ctx$n)), refined$C[j, 1],
               tolerance = 1e-8)
})

# One theta in [0, 1]; a joint design dense in its middle with one run near
# each edge, so the emulator knows little there; replicated field data from
# theta = 0.5 with a discrepancy no run removes.
edge_system <- function(discrepancy = 0.5) {
  sim <- function(x, th) sin(2 * pi * x) + sin(6 * th) * (1 + x)
  set.seed(3)
  th <- c(stats::runif(24, 0.3, 0.7), 0.02, 0.98)
  xs <- stats::runif(length(th))
  settings <- data.frame(x = seq(0.05, 0.95, length.out = 10))
  lib <- emulated_library(data.frame(theta = th), matrix(sim(xs, th)), x = data.frame(x = xs),
                          t = 1, settings = settings, n_runs = 2000, seed = 1)
  fx <- rep(settings$x, each = 5)
  y <- sim(fx, 0.5) + discrepancy * cos(3 * fx) + stats::rnorm(length(fx), sd = 0.05)
  list(lib = lib, field = field_data(matrix(y), x = data.frame(x = fx), t = 1))
}

test_that("the emulator's error does not pull the posterior to the design's edges", {
  skip_if_not_installed("RobustGaSP")
  sys <- edge_system()
  theta <- sys$lib$theta$theta
  # the emulator knows much less at the edges
  expect_gt(mean(sys$lib$rel_var[theta > 0.9]), 20 * mean(sys$lib$rel_var[abs(theta - 0.5) < 0.1]))
  post <- suppressWarnings(posterior_exact(sys$lib, sys$field))
  expect_lt(sum(post$run[theta < 0.15 | theta > 0.85]), 0.01)
  expect_gt(sum(post$run[theta > 0.3 & theta < 0.7]), 0.99)
})

test_that("data no run fits are said to be so, against the replicates' pure error", {
  skip_if_not_installed("RobustGaSP")
  sys <- edge_system()
  expect_warning(posterior_exact(sys$lib, sys$field), class = "griddy_warning_lack_of_fit")
  fits <- edge_system(discrepancy = 0)
  expect_no_warning(post <- posterior_exact(fits$lib, fits$field))
  theta <- fits$lib$theta$theta
  expect_gt(sum(post$run[abs(theta - 0.5) < 0.05]), 0.95)
})

test_that("the emulation check's noise scale is one the emulator's error cannot inflate", {
  skip_if_not_installed("RobustGaSP")
  # with replicates: their pure error, whatever the plug-in
  sys <- edge_system()
  fit <- suppressWarnings(calibrate(sys$lib, sys$field, n_iter = 200, burn_in = 50, seed = 1))
  setup <- fit$setup
  pure <- sum(setup$pure_ss) / 40
  expect_equal(reference_noise_var(setup, 100, fit$C), pure)
  expect_equal(reference_noise_var(setup, 1e-6, fit$C), pure)
  # without: never above the best run's misfit per data point under the error
  lib <- emulated_toy_library(n_runs = 300)
  fit <- suppressWarnings(calibrate(lib, emulated_toy_field(), n_iter = 200, burn_in = 50,
                                    seed = 1))
  expect_equal(reference_noise_var(fit$setup, 100, fit$C), min(fit$C) / 30)
  expect_equal(reference_noise_var(fit$setup, 1e-8, fit$C), 1e-8)
})

test_that("a useless emulator warns, against replicates' noise", {
  skip_if_not_installed("RobustGaSP")
  d <- emulated_toy_design(30, seed = 1)
  set.seed(5)
  # a simulator the GP cannot learn: its outputs jitter by 0.3 from run to run
  y <- d$y + matrix(stats::rnorm(length(d$y), sd = 0.3), nrow(d$y))
  lib <- emulated_library(d$theta, y, x = data.frame(x = d$x), t = d$t, settings = d$settings,
                          n_runs = 300, seed = 1)
  truth <- matrix(emulated_truth(cbind(k = 2.1, c = 0.3)), 3, 10, byrow = TRUE)
  yf <- truth[rep(1:3, each = 3), ] + stats::rnorm(90, sd = 0.02)
  field <- field_data(yf, x = data.frame(x = rep(c(0.2, 0.5, 0.8), each = 3)), t = d$t)
  # (and no run fits the data by its predictions: said too)
  expect_warning(expect_warning(posterior_exact(lib, field), class = "griddy_warning_emulation"),
                 class = "griddy_warning_lack_of_fit")
})

test_that("an emulated library too large for memory is refused before it is built", {
  skip_if_not_installed("RobustGaSP")
  d <- emulated_toy_design(20)
  expect_error(emulated_library(d$theta, d$y, x = data.frame(x = d$x), t = d$t,
                                settings = d$settings, n_runs = 2e9),
               class = "griddy_error_memory")
  expect_identical(assert_emulated_size(1e4, 2, 3, 10), 8 * 1e4 * (90 + 6 + 8 + 2))
})

test_that("an emulated library's fit keeps its noise plug-in, and its group forms agree with C", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 300)
  fit <- suppressWarnings(calibrate(lib, emulated_toy_field(), noise_groups = "x", n_iter = 200,
                                    burn_in = 50, seed = 1))
  noise <- fit$library$noise
  expect_length(noise$noise_var, 3)
  expect_identical(noise$y_field, fit$y_field)
  runs <- 1:5
  Ck <- run_group_forms(fit, runs, 1)
  err <- lib$error
  err$noise_var <- noise$noise_var
  em <- emulated_quad_forms(lib$y[runs, ], fit$y_field, fit$setup, err, rep(noise$kappa, 5), 3, 10)
  expect_equal(fold_groups(Ck, fit$setup), em$C[, 1])
  C <- list(C = em$C, extra_logdet = em$logdet)
  expect_equal(fold_extra_logdet(C, fit$prior, fit$n_obs)[, 1], fit$C[runs, 1])
  # the tau draws see the error too: not the plain forms
  expect_false(isTRUE(all.equal(Ck, group_quad_forms(lib$y[runs, ], fit$y_field, fit$setup, 1))))
})

test_that("with missing cells and sd, a predicted run's pieces are those of its dense covariance", {
  toy <- refine_toy()
  y <- toy$field$y
  y[c(5:9, 30)] <- NA
  rs <- 1 + 0.3 * sin(1:40)
  field <- field_data(y, t = toy$lib$t, sd = rs)
  fit <- suppressWarnings(calibrate(toy$lib, field, n_iter = 300, burn_in = 100, seed = 1))
  # short chains: their R-hat may trip by chance (see ?calibrate)
  refined <- suppressWarnings(refine(fit, max_runs = 200, runs_per_round = 100, seed = 2),
                              classes = "griddy_warning_convergence")
  lib <- refined$library
  ctx <- gap_context(refined)
  obs <- ctx$obs
  point <- ctx$points[[1]]
  j <- lib_n_runs(lib$base) + 5L
  err <- run_emulation(run_errors(lib), j, obs)
  r <- (refined$y_field - lib_outputs(lib, j)[1, ])[obs]
  wood <- emulated_inverse(ctx, point, r, err)
  S <- diag(rs[obs]^2) + tcrossprod(err$V)
  Si <- solve(S)
  expect_equal(wood$Q, drop(t(r) %*% Si %*% r), tolerance = 1e-10)
  expect_equal(wood$logdet, as.numeric(determinant(S)$modulus) - 2 * sum(log(rs[obs])),
               tolerance = 1e-10)
  # the same likelihood as the refined fit's own table
  C <- list(C = matrix(wood$Q), extra_logdet = matrix(wood$logdet))
  expect_equal(drop(fold_extra_logdet(C, refined$prior, ctx$n)), refined$C[j, 1], tolerance = 1e-8)
  B <- 11:20
  bs <- emulated_block(wood, block_precision(ctx, point, B, B, 1L), B)
  h <- Si %*% r
  expect_equal(bs$D, drop(t(h[B]) %*% solve(Si[B, B], h[B])), tolerance = 1e-10)
  expect_equal(bs$logdet_BB, as.numeric(determinant(Si[B, B])$modulus), tolerance = 1e-10)
})

test_that("the field's roughness gives the noise scale a smooth misfit cannot inflate", {
  # the best run misses the data by a smooth curve five times the noise
  t <- seq(0, 1, length.out = 40)
  x <- data.frame(load = c(1, 2))
  set.seed(9)
  truth <- rep(sin(2 * pi * t), 2)
  y <- truth + 0.5 * rep(cos(pi * t), 2) + stats::rnorm(80, sd = 0.1)
  lib <- sim_library(data.frame(k = c(1, 2)), rbind(truth, truth + 3), x = x, t = t)
  setup <- correlation_setup(lib, 0, 0)
  state <- list(problem = new_griddy_problem(lib, y, thesis_prior(), rep(-log(2), 2), setup),
                p = c(1, 0), joint = NULL)
  rough <- roughness_noise_var(state)
  expect_gt(sqrt(rough), 0.07)
  expect_lt(sqrt(rough), 0.14)
  # the misfit per point, which the smooth miss inflates, is bounded by it
  C <- matrix(sum((y - truth)^2), 1)
  expect_gt(sqrt(C[1] / 80), 0.3)
  expect_equal(reference_noise_var(setup, 1, C, rough), rough)
  # too few differences: no estimate
  short <- sim_library(data.frame(k = c(1, 2)), matrix(rnorm(6), 2), t = 1:3)
  state$problem <- new_griddy_problem(short, rnorm(3), thesis_prior(), rep(-log(2), 2),
                                      correlation_setup(short, 0, 0))
  expect_null(roughness_noise_var(state))
})
