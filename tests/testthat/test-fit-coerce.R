test_that("as.data.frame joins theta and rho values to the draws", {
  toy <- toy_xt(n_per_dim = 4, n_t = 6)
  fit <- suppressWarnings(
    calibrate(toy$library, toy$field, rho_x = list(load = c(0, 0.5), speed = 0),
              n_iter = 300, burn_in = 100, chains = 2, seed = 1),
    classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
  d <- as.data.frame(fit)
  expect_identical(names(d), c("chain", "iteration", "run", "a", "b", "tau", "rho_x_load",
                               "rho_x_speed", "rho_t"))
  expect_identical(nrow(d), 400L)
  expect_identical(d$a, toy$library$theta$a[d$run])
  expect_identical(d$rho_x_load, fit$grid$rho_x_load[fit$draws$grid_point])
})

test_that("as.mcmc.list gives one mcmc per chain with the sampled parameters", {
  toy <- toy_xt(n_per_dim = 4, n_t = 6)
  fit <- suppressWarnings(
    calibrate(toy$library, toy$field, rho_x = list(load = c(0, 0.5), speed = 0),
              n_iter = 300, burn_in = 100, thin = 2, chains = 2, seed = 1),
    classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
  mc <- coda::as.mcmc.list(fit)
  expect_s3_class(mc, "mcmc.list")
  expect_identical(coda::nchain(mc), 2L)
  expect_identical(coda::varnames(mc), c("a", "b", "tau", "rho_x_load"))
  expect_identical(stats::start(mc), 102)
  expect_identical(coda::thin(mc), 2)
  expect_identical(as.vector(mc[[2]][, "tau"]), fit$draws$tau[fit$draws$chain == 2])
})
