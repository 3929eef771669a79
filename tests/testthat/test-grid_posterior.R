test_that("whitening and colouring are inverse and give the quadratic forms", {
  toy <- toy_xt(n_per_dim = 3, n_t = 6)
  lib <- toy$library
  y <- field_vector(lib, toy$field)
  setup <- correlation_setup(lib, rho_x = list(load = 0.6, speed = 0.3), rho_t = c(0, 0.5))
  C <- misfit_table(lib, y, setup)
  E <- -sweep(lib$y, 2, y, "-")
  for (g in seq_len(n_grid_points(setup))) {
    point <- grid_point(setup, g)
    W <- whiten_rows(E, point, 3L, 6L)
    expect_equal(rowSums(W^2), C[, g], tolerance = 1e-10)
    expect_equal(colour_rows(W, point, 3L, 6L), E, tolerance = 1e-10)
  }
})

test_that("the collapsed log joint sums to the log evidence and matches the dense formula", {
  toy <- toy_ar1(n_runs = 30, n_t = 15)
  problem <- calibration_problem(toy$library, toy$field, 0, c(0, 0.4), NULL, 2, NULL)
  lj <- collapsed_log_joint(problem$C, problem$n_obs, problem$setup$logdet, problem$prior,
                            problem$log_prior_run, problem$log_prior_grid)
  expect_equal(log_sum_exp(lj), posterior_exact(toy$library, toy$field,
                                                rho_t = c(0, 0.4))$log_evidence)
  y <- field_vector(toy$library, toy$field)
  R <- corr_t(toy$library$t, 0.4)
  r <- y - toy$library$y[7, ]
  a <- 1e-9
  b <- 1e-9
  n <- 15
  dense <- a * log(b) - lgamma(a) + lgamma(a + n / 2) - n / 2 * log(2 * pi) -
    determinant(R)$modulus[1] / 2 - (a + n / 2) * log(b + drop(r %*% solve(R, r)) / 2) -
    log(30) - log(2)
  expect_equal(lj[7, 2], dense, tolerance = 1e-10)
})

test_that("a rho_t whose neighbour correlation rounds to 1 is refused", {
  toy <- toy_ar1(n_runs = 20, n_t = 10)
  expect_error(calibrate(toy$library, toy$field, rho_t = c(0, 1 - 2^-53), n_iter = 10,
                         burn_in = 0),
               class = "griddy_error_input", regexp = "rounds to 1")
  expect_error(posterior_exact(toy$library, toy$field, rho_t = 1 - 2^-53),
               class = "griddy_error_input")
})

test_that("a misfit that overflows is an error naming the output scale, never NaN weights", {
  toy <- toy_ar1(n_runs = 20, n_t = 10)
  big <- sim_library(toy$library$theta, toy$library$y * 1e154, t = toy$library$t)
  field <- field_data(toy$field$y * 1e154)
  expect_error(calibrate(big, field, n_iter = 100, burn_in = 10, seed = 1),
               class = "griddy_error_numeric", regexp = "overflow")
  expect_error(posterior_exact(big, field), class = "griddy_error_numeric")
})

test_that("the C++ entry points refuse shapes that do not fit", {
  Y <- matrix(1, 4, 6)
  cube <- array(diag(2), c(2, 2, 1))
  expect_error(quad_forms_cpp(Y, rep(1, 5), cube, matrix(0, 2, 1)), "do not split")
  expect_error(quad_forms_cpp(Y, rep(1, 8), cube, matrix(0, 3, 1)), "columns")
  expect_error(quad_forms_cpp(Y, rep(1, 6), cube, matrix(0, 3, 1)), "lag coefficients")
  Y[2, 3] <- NA
  expect_error(quad_forms_cpp(Y, rep(1, 6), cube, matrix(0, 2, 1)), "not finite")
  C <- matrix(c(1, NaN), 2, 1)
  expect_error(collapsed_heads_cpp(C, c(0, 0), 1, 1, 0), "NA, NaN or Inf")
  expect_error(collapsed_heads_cpp(matrix(1, 3, 1), c(0, 0), 1, 1, 0), "run priors")
  options <- list(update = "thesis", n_obs = 2, shape = 1, rate = 1, tol = 0, n_iter = 5,
                  first_iter = 1L, burn_in = 0L, thin = 1L, logdet = 0, log_prior_run = c(0, 0),
                  log_prior_grid = 0)
  # a draw never returns a run of zero weight: all-NaN weights are an error
  C <- matrix(NaN, 2, 1)
  expect_error(run_order_cpp(C), "NA, NaN or Inf")
  expect_error(gibbs_chain_cpp(C, list(order = matrix(0:1, 2, 1)), options, 0L, 1),
               "weights sum to")
  options$log_prior_run <- 0
  expect_error(gibbs_chain_cpp(matrix(1, 2, 1), list(order = matrix(0L, 2, 1)), options, 0L, 1),
               "run priors")
  options$log_prior_run <- c(0, 0)
  expect_error(gibbs_chain_cpp(matrix(1, 2, 1), list(order = matrix(0L, 2, 1)), options, 3L, 1),
               "starting grid point")
})
