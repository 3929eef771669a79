test_that("one library in memory, in HDF5 (both orientations) and in an old .rds directory gives identical results", {
  skip_if_not_installed("hdf5r")
  toy <- toy_xt(n_per_dim = 8)
  mem <- toy$library
  rds_dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(mem, rds_dir, chunk_size = 15)
  first <- withr::local_tempfile(fileext = ".h5")
  last <- withr::local_tempfile(fileext = ".h5")
  write_user_h5(mem, first, layout = "runs_first", theta_as = "compound")
  write_user_h5(mem, last, layout = "runs_last", theta_as = "matrix")
  own <- withr::local_tempfile(fileext = ".h5")
  write_library(mem, own, chunk_size = 9)
  libs <- list(
    rds = disk_library(rds_dir, trust = TRUE),
    h5_runs_first = hdf5_library(first, theta = "params", outputs = "sim/out", x = mem$x,
                                 t = "sim/time", chunk_size = 11),
    h5_runs_last = hdf5_library(last, theta = "params", outputs = "sim/out", x = mem$x,
                                t = "sim/time", chunk_size = 64),
    h5_written = hdf5_library(own, chunk_size = 20))
  expect_identical(libs$h5_runs_first$layout, "runs_first")
  expect_identical(libs$h5_runs_last$layout, "runs_last")
  rho <- list(rho_x = c(0, 0.3), rho_t = c(0, 0.5))
  exact <- posterior_exact(mem, toy$field, rho$rho_x, rho$rho_t)
  draws <- lapply(c("collapsed", "thesis"), function(u) {
    suppressWarnings(
      calibrate(mem, toy$field, rho$rho_x, rho$rho_t, n_iter = 500, burn_in = 100, update = u,
                seed = 7),
      classes = c("griddy_warning_resolution", "griddy_warning_convergence"))$draws
  })
  for (nm in names(libs)) {
    lib <- libs[[nm]]
    expect_true(is_library(lib))
    expect_identical(lib_n_runs(lib), lib_n_runs(mem))
    expect_identical(lib_n_out(lib), lib_n_out(mem))
    e <- posterior_exact(lib, toy$field, rho$rho_x, rho$rho_t)
    expect_identical(e$joint, exact$joint, label = nm)
    expect_identical(e$log_evidence, exact$log_evidence, label = nm)
    for (k in 1:2) {
      u <- c("collapsed", "thesis")[k]
      fit <- suppressWarnings(
        calibrate(lib, toy$field, rho$rho_x, rho$rho_t, n_iter = 500, burn_in = 100,
                  update = u, seed = 7),
        classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
      expect_identical(fit$draws, draws[[k]], label = paste(nm, u))
    }
    fit_mem <- suppressWarnings(
      calibrate(mem, toy$field, rho$rho_x, rho$rho_t, n_iter = 500, burn_in = 100,
                update = "thesis", seed = 7),
      classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
    expect_identical(predict(fit, seed = 1), predict(fit_mem, seed = 1), label = nm)
  }
})

test_that("check_library() accepts every backend and names them when refusing", {
  toy <- toy_ar1(n_runs = 10, n_t = 5)
  expect_invisible(check_library(toy$library))
  expect_error(check_library(list(theta = 1)),
               "must be a sim_library \\(see \\?sim_library\\), an hdf5_library .* or a disk_library")
  expect_error(check_library(toy$field, disk = FALSE), "must be a sim_library \\(see \\?sim_library\\); received")
})

test_that("an edited sim_library is a shape error before any C++", {
  toy <- toy_ar1(n_runs = 10, n_t = 5)
  bad <- toy$library
  bad$theta$theta[3] <- NA
  expect_error(posterior_exact(bad, toy$field), "sim_library has been edited.*NA at \\[3, theta\\]",
               class = "griddy_error_shape")
  bad <- toy$library
  bad$theta <- bad$theta[-1, , drop = FALSE]
  expect_error(calibrate(bad, toy$field, n_iter = 50, burn_in = 5), "sim_library has been edited",
               class = "griddy_error_shape")
  bad <- toy$library
  bad$y[2, 2] <- Inf
  expect_error(posterior_exact(bad, toy$field), "library\\$y` must hold finite numbers; found Inf",
               class = "griddy_error_shape")
})

test_that("lib_outputs() rejects rows outside the library", {
  toy <- toy_ar1(n_runs = 10, n_t = 5)
  expect_error(lib_outputs(toy$library, c(0, 11)), "whole numbers in 1..10; received 0, 11",
               class = "griddy_error_shape")
})
