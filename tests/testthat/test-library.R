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

test_that("a plain library tells refine() it has no rounds, no predicted runs, no error models", {
  toy <- refine_toy()
  lib <- toy$lib
  expect_identical(lib_base(lib), lib)
  expect_identical(lib_rounds(lib), list())
  expect_identical(lib_predicted(lib), logical(lib_n_runs(lib)))
  expect_identical(lib_simulated(lib), lib)
  expect_identical(lib_noise_var(lib), numeric())
  expect_null(lib_prediction_errors(lib))
  expect_identical(lib_with_noise_var(lib, 0.1, 1), lib)
  setup <- toy$fit$setup
  y <- toy$fit$y_field
  expect_equal(lib_run_quad_forms(lib, 2:3, y, setup), lib_quad_forms(lib, y, setup)[2:3, , drop = FALSE])
})

test_that("a refined library's interface: rounds, predicted runs, replacements, noise scale", {
  toy <- refine_toy()
  ref <- suppressWarnings(refine(toy$fit, max_runs = 100, runs_per_round = 50, seed = 1))
  lib <- ref$library
  setup <- ref$setup
  y <- ref$y_field
  expect_identical(lib_base(lib), toy$lib)
  expect_length(lib_rounds(lib), 2L)
  expect_identical(lib_predicted(lib), rep(c(FALSE, TRUE), c(7L, 100L)))
  expect_equal(lib_theta(lib_simulated(lib)), lib_theta(toy$lib), ignore_attr = TRUE)
  expect_length(lib_noise_var(lib), 2L)
  half <- lib_with_noise_var(lib, lib_noise_var(lib)[1] / 2, y)
  expect_equal(lib_noise_var(half), rep(lib_noise_var(lib)[1] / 2, 2))
  expect_equal(lib_prediction_errors(lib)$round, rep(1:2, each = 50))
  # forms of some rows agree with those of the whole library
  all_C <- lib_quad_forms(lib, y, setup)
  rows <- c(3L, 20L, 90L)
  some <- lib_run_quad_forms(lib, rows, y, setup)
  expect_equal(some$C, all_C$C[rows, , drop = FALSE])
  expect_equal(some$extra_logdet, all_C$extra_logdet[rows, , drop = FALSE])
  # a replaced run is simulated: its outputs, plain forms, no longer predicted
  sim_y <- refine_sim(lib_theta(lib)[20, , drop = FALSE])
  rep_lib <- replace_runs(lib, 20L, sim_y)
  expect_equal(lib_outputs(rep_lib, 20L), sim_y, ignore_attr = TRUE)
  expect_false(lib_predicted(rep_lib)[20])
  expect_equal(lib_run_quad_forms(rep_lib, 20L, y, setup)$C[1, ],
               plain_quad_forms(sim_y, y, setup)[1, ], ignore_attr = TRUE)
  expect_equal(lib_log_prior(rep_lib), lib_log_prior(lib))
  rep_problem <- new_griddy_problem(rep_lib, y, ref$prior, lib_log_prior(rep_lib), setup)
  expect_equal(run_group_forms(rep_problem, 20L, 1L),
               group_quad_forms(sim_y, y, setup, 1L), ignore_attr = TRUE)
})
