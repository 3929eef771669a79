test_that("a joint (x, theta) design in the thesis's files gives an emulated library and says so", {
  skip_if_not_installed("RobustGaSP")
  d <- emulated_toy_design()
  dir <- tempfile("griddy-joint")
  dir.create(dir)
  on.exit(unlink(dir, recursive = TRUE))
  paths <- file.path(dir, c("design.csv", "simobs.csv", "expobs.csv"))
  data.table::fwrite(data.frame(x = d$x, d$theta), paths[1])
  data.table::fwrite(as.data.frame(d$y), paths[2])
  field <- emulated_toy_field()
  data.table::fwrite(data.frame(x = c(0.2, 0.5, 0.8), field$y), paths[3])
  expect_message(
    out <- read_calibration_inputs(paths[1], paths[2], paths[3], n_x = 1, t = d$t,
                                   n_runs = 500, seed = 1),
    class = "griddy_message_emulated")
  lib <- out$library
  expect_s3_class(lib, "emulated_library")
  expect_identical(lib$emulator$mode, "joint")
  expect_identical(lib_n_runs(lib), 500L)
  expect_equal(lib$x, data.frame(x = c(0.2, 0.5, 0.8)))
  expect_identical(dim(lib_outputs(lib)), c(500L, 30L))
  expect_equal(field_vector(lib, out$field), as.vector(t(field$y)), tolerance = 1e-12)
  expect_output(print(lib), "40 design runs")
  expect_output(print(lib), "leave-one-out error")
})

test_that("a complete design still gives a sim_library, and an incomplete one is emulated", {
  skip_if_not_installed("RobustGaSP")
  set.seed(4)
  theta <- expand.grid(k = seq(1, 3, length.out = 6), c = seq(0.1, 0.5, length.out = 5))
  grid <- merge(data.frame(x = c(0.2, 0.8)), theta)
  y <- t(vapply(seq_len(nrow(grid)), function(i) {
    emulated_sim(grid$x[i], as.matrix(grid[i, c("k", "c")]))
  }, numeric(10)))
  expobs <- data.frame(x = c(0.2, 0.8), matrix(0, 2, 10))
  full <- read_calibration_inputs(grid, y, expobs, n_x = 1)
  expect_s3_class(full$library, "sim_library")
  # one run missing: the rest train the emulator, none is dropped
  expect_message(part <- read_calibration_inputs(grid[-3, ], y[-3, ], expobs, n_x = 1,
                                                 n_runs = 200, seed = 1),
                 class = "griddy_message_emulated")
  expect_s3_class(part$library, "emulated_library")
  expect_identical(nrow(part$library$design$theta), nrow(grid) - 1L)
  # a field setting no run has
  expobs3 <- data.frame(x = c(0.2, 0.5, 0.8), matrix(0, 3, 10))
  expect_message(mid <- read_calibration_inputs(grid, y, expobs3, n_x = 1, n_runs = 200,
                                                seed = 1),
                 class = "griddy_message_emulated")
  truth <- emulated_truth(as.matrix(mid$library$theta), c(0.2, 0.5, 0.8))
  err <- lib_outputs(mid$library) - truth
  expect_lt(sqrt(mean(err[, c(1:10, 21:30)]^2)), 0.02)
  # at the setting no run has, the GP is less sure, and says so
  var <- design_gp_predict(mid$library$emulator, as.matrix(mid$library$theta))$var
  expect_gt(mean(var[, 2]), 10 * mean(var[, 1]))
})

test_that("held-out runs of a smooth toy are predicted within tolerance, the same with a seed", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 300)
  truth <- emulated_truth(as.matrix(lib$theta))
  rms <- sqrt(mean((lib_outputs(lib) - truth)^2))
  expect_lt(rms, 0.03)
  expect_lt(rms, 3 * lib$loo_rms)
  expect_true(all(lib$rel_var > 0))
  again <- emulated_toy_library(n_runs = 300)
  expect_identical(lib$y, again$y)
  expect_identical(lib$theta, again$theta)
})

test_that("the library finds its noise variance near the truth's and calibrate() covers the truth", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 3000)
  field <- emulated_toy_field(sd = 0.02)
  y <- as.vector(t(field$y))
  fixed <- emulated_noise_var(lib, y, correlation_setup(lib, list(x = 0), 0))
  expect_gt(fixed$noise_var, 0.01^2)
  expect_lt(fixed$noise_var, 0.04^2)
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 3000, burn_in = 500, seed = 1))
  post <- posterior_exact(lib, field)
  expect_gt(sum(post$run[lib$theta$k < 2.1]), 0.01)
  expect_gt(sum(post$run[lib$theta$k > 2.1]), 0.01)
  expect_gt(sum(post$run[lib$theta$c < 0.3]), 0.01)
  expect_gt(sum(post$run[lib$theta$c > 0.3]), 0.01)
  s <- summary(fit)
  expect_true(s$lower[s$parameter == "k"] < 2.1 && s$upper[s$parameter == "k"] > 2.1)
  # the emulator's error against the noise is reported, as the library found it
  expect_equal(attr(s, "adequacy")$emulation_error,
               emulated_noise_var(lib, y, fit$setup)$ratio)
  expect_match(format_adequacy(attr(s, "adequacy")), "leave-one-out error near the posterior",
               all = FALSE)
})

test_that("an emulator worse than the noise is said in a classed warning", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n = 12, n_runs = 300)
  field <- emulated_toy_field(sd = 1e-4)
  expect_warning(posterior_exact(lib, field), class = "griddy_warning_emulation")
})

test_that("refine() without a simulator predicts with the library's own emulator", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 400)
  field <- emulated_toy_field()
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 1000, burn_in = 200, seed = 1))
  state <- refine_state(fit)
  em <- round_emulator(state, library_box(lib))
  expect_identical(em$method, "emulated_library")
  ref <- suppressWarnings(refine(fit, max_runs = 200, runs_per_round = 100, seed = 1))
  added <- ref$library$added
  new_theta <- as.matrix(lib_theta(ref$library))[-seq_len(400), , drop = FALSE]
  expect_equal(added$y, unname(design_gp_predict(lib$emulator, new_theta)$mean))
  expect_false(is.null(ref$library$rounds[[1]]$error))
  # the base's runs were restated with the rounds' noise variance
  expect_equal(ref$library$base$noise$noise_var,
               ref$library$rounds[[length(ref$library$rounds)]]$error$noise_var,
               tolerance = 0.02)
  expect_true(is.finite(ref$refinement$emulation_error))
})

test_that("koh_calibrate() takes an emulated library, with its own emulator as the math model", {
  skip_if_not_installed("RobustCalibration")
  lib <- emulated_toy_library(n_runs = 100)
  field <- emulated_toy_field()
  koh <- koh_calibrate(lib, field, discrepancy = "none", n_iter = 400, burn_in = 100,
                       tune_rounds = 1, tune_iter = 100, seed = 1)
  expect_identical(koh$n_runs, 40L)
  expect_false(is.null(koh$emulator$design_gp))
  expect_identical(nrow(predict(koh, ndraws = 20)), 30L)
})

test_that("emulated_library() checks its arguments", {
  d <- emulated_toy_design()
  expect_error(emulated_library(d$theta, d$y[-1, ]), "one row per run")
  expect_error(emulated_library(d$theta, d$y, settings = d$settings), "needs the runs' `x`")
  expect_error(emulated_library(d$theta, d$y, x = data.frame(x = d$x),
                                settings = data.frame(z = 1)), "`x`'s columns")
  expect_error(emulated_library(d$theta, d$y, x = d$x[-1]), "one row per run")
  expect_error(emulated_library(d$theta, d$y, x = data.frame(x = d$x), n_runs = 1), "n_runs")
  skip_if_not_installed("RobustGaSP")
  expect_error(emulated_library(d$theta[c(1, 1:5), ], d$y[c(1, 1:5), ],
                                x = data.frame(x = d$x[c(1, 1:5)])),
               "duplicated \\(x, theta\\) runs")
  expect_error(emulated_library(d$theta[1:4, ], d$y[1:4, ], x = data.frame(x = d$x[1:4])),
               "at least 6 design runs")
})

test_that("print.emulated_library() shows the design, the emulator and the error", {
  skip_if_not_installed("RobustGaSP")
  expect_snapshot(print(emulated_toy_library(n_runs = 300)))
})

test_that("emulated_library(t_out =) builds the library at other output coordinates", {
  skip_if_not_installed("RobustGaSP")
  set.seed(2)
  design <- data.frame(x = runif(20), k = runif(20, 1, 2))
  t <- seq(0, 1, by = 0.1)
  y <- t(apply(design, 1, function(r) r[["k"]] * t^2 + r[["x"]]))
  t_out <- c(0.25, 0.55, 0.95)
  lib <- emulated_library(design["k"], y, x = design["x"], t = t,
                          settings = data.frame(x = 0.5), n_runs = 50, seed = 1, t_out = t_out)
  expect_identical(lib$t, t_out)
  expect_identical(lib$interpolation$t, t)
  expect_lt(lib$interpolation$loo_rms, 1e-10)  # a quadratic in t: the spline is exact
  truth <- outer(lib$theta$k, t_out^2) + 0.5
  expect_lt(max(abs(lib$y - truth)), 0.05)
  expect_output(print(lib), "interpolated to 3 coordinate")
  expect_error(emulated_library(design["k"], y, x = design["x"], t = t, n_runs = 50,
                                t_out = c(0.5, 1.5)), "lie outside")
})

test_that("settings outside the design's range of x are named in a warning (issue 32)", {
  skip_if_not_installed("RobustGaSP")
  d <- emulated_toy_design()
  # before: x = 5 for a design over [0, 1] was predicted without a word
  expect_warning(
    lib <- emulated_library(d$theta, d$y, x = data.frame(x = d$x), t = d$t,
                            settings = data.frame(x = c(0.5, 5)), n_runs = 200, seed = 1),
    "x = 5 \\(1 setting\\(s\\); 4.* beyond the design's \\[0.0.*, 0.9.*\\]",
    class = "griddy_warning_extrapolation")
  expect_s3_class(lib, "emulated_library")
  # the warning is an emulation warning too, and settings inside stay quiet
  expect_warning(emulated_library(d$theta, d$y, x = data.frame(x = d$x), t = d$t,
                                  settings = data.frame(x = -1), n_runs = 200, seed = 1),
                 class = "griddy_warning_emulation")
  expect_no_warning(emulated_library(d$theta, d$y, x = data.frame(x = d$x), t = d$t,
                                     settings = data.frame(x = c(0.2, 0.8)), n_runs = 200,
                                     seed = 1))
})
