# A tiny problem: outputs linear in two parameters at 8 x settings, so a
# 25-run emulator is essentially exact and the posterior must sit at the truth.
koh_toy <- function(noise_sd = 0.02, seed = 3, x = seq(0, 1, length.out = 8)) {
  g <- function(th) th[1] * sin(3 * x) + th[2] * x^2
  theta <- expand.grid(a = seq(0, 2, length.out = 5), b = seq(1, 3, length.out = 5))
  y <- t(apply(as.matrix(theta), 1, g))
  lib <- sim_library(theta, y, x = data.frame(x = x))
  set.seed(seed)
  obs <- g(c(1.3, 2.2)) + stats::rnorm(8, sd = noise_sd)
  list(library = lib, field = field_data(matrix(obs), x = data.frame(x = x)),
       truth = c(a = 1.3, b = 2.2))
}

test_that("koh_calibrate() recovers the truth of a tiny problem (GaSP and no discrepancy)", {
  skip_if_not_installed("RobustCalibration")
  toy <- koh_toy()
  for (d in c("GaSP", "none")) {
    wall <- system.time(
      fit <- koh_calibrate(toy$library, toy$field, discrepancy = d, n_iter = 3000,
                           burn_in = 1000, tune_iter = 300, seed = 11))[["elapsed"]]
    expect_s3_class(fit, "griddy_koh")
    expect_equal(nrow(fit$draws), 2000)
    s <- summary(fit)
    expect_equal(s$parameter, c("a", "b"))
    expect_true(all(s$lower <= s$mean & s$mean <= s$upper))
    expect_equal(s$mean, unname(toy$truth), tolerance = 0.05)
    expect_true(all(s$lower < toy$truth & toy$truth < s$upper))
    expect_true(all(s$ess_bulk > 20))
    expect_true(all(c("ess_tail", "rhat", "mcse") %in% names(s)))
    # the three phases are timed, and together are within the call's time
    expect_named(fit$runtime, c("emulator", "tuning", "sampling"))
    expect_gt(fit$runtime[["sampling"]], 0)
    expect_lte(sum(fit$runtime), wall + 0.05)
    p <- predict(fit, ndraws = 100)
    expect_equal(nrow(p), 8)
    expect_equal(p$observed, drop(toy$field$y))
    expect_lt(max(abs(p$mean - p$observed)), 0.2)
    if (d == "none") {
      # without a discrepancy sigma2 is the noise variance (sd 0.02)
      expect_true(stats::quantile(fit$draws$sigma2, 0.025) < 0.02^2)
      expect_true(0.02^2 < stats::quantile(fit$draws$sigma2, 0.975))
    }
  }
})

test_that("koh_calibrate() takes field data with missing cells (they were refused)", {
  skip_if_not_installed("RobustCalibration")
  toy <- koh_toy()
  y <- toy$field$y
  y[c(2, 5)] <- NA
  field <- field_data(y, x = toy$library$x)
  fit <- koh_calibrate(toy$library, field, discrepancy = "none", n_iter = 3000,
                       burn_in = 1000, tune_iter = 300, seed = 11)
  s <- summary(fit)
  expect_true(all(s$lower < toy$truth & toy$truth < s$upper))
  p <- predict(fit, ndraws = 100)
  expect_equal(nrow(p), 8)
  expect_true(all(is.na(p$observed[c(2, 5)])))
  expect_error(koh_calibrate(toy$library, field_data(toy$field$y, x = toy$library$x,
                                                      sd = rep(1, 8))),
               "relative `sd`", class = "griddy_error_unsupported")
})

test_that("koh_calibrate() is reproducible with a seed and keeps the global stream", {
  skip_if_not_installed("RobustCalibration")
  toy <- koh_toy()
  set.seed(5)
  before <- stats::runif(1)
  set.seed(5)
  a <- koh_calibrate(toy$library, toy$field, n_iter = 300, burn_in = 100,
                     tune_rounds = 1, tune_iter = 50, seed = 2)
  after <- stats::runif(1)
  b <- koh_calibrate(toy$library, toy$field, n_iter = 300, burn_in = 100,
                     tune_rounds = 1, tune_iter = 50, seed = 2)
  expect_identical(a$draws, b$draws)
  expect_identical(before, after)
})

test_that("koh_calibrate() validates its arguments", {
  skip_if_not_installed("RobustCalibration")
  toy <- koh_toy()
  expect_error(koh_calibrate(toy$library, toy$field, n_iter = 100, burn_in = 100),
               "`burn_in` must be smaller")
  expect_error(koh_calibrate(toy$library, toy$field, proposal_sd = c(0.1, -1)),
               "`proposal_sd` must hold 2 positive")
  expect_error(koh_calibrate(toy$library, toy$field, discrepancy = "GP"), class = "griddy_error_input", regexp = "`discrepancy` must be one of")
  expect_error(koh_calibrate(toy$library, list()), "must be a griddy_field")
})

test_that("the shipped chapter-4 comparison has the thesis's tables 4.1-4.5", {
  path <- system.file("extdata", "chapter4.rds", package = "griddy")
  skip_if(path == "", "chapter4.rds not installed")
  ch4 <- readRDS(path)
  htc <- c("htc_undercrown", "htc_gallery1", "htc_gallery2")
  tab <- ch4$tables[ch4$tables$parameter %in% htc, ]
  # the thesis's comparison (no discrepancy in the data model) and our extension
  methods <- c("Griddy Gibbs", "KOH (no discrepancy)", "KOH (GaSP)", "KOH (S-GaSP)")
  for (n in c(6, 15, 27, 54)) {
    d <- tab[tab$n_points == n & tab$method %in% methods, ]
    expect_equal(nrow(d), 12)
    expect_setequal(d$method, methods)
    expect_true(all(c("lower", "estimate", "median", "truth", "upper") %in% names(d)))
    # (a discrete posterior's mean may lie outside an interval collapsed to
    # one library value, as in the thesis's tables; its median may not)
    expect_true(all(d$lower <= d$median & d$median <= d$upper))
    expect_equal(unname(d$truth[match(htc, d$parameter)]), c(1000, 3000, 2000))
  }
  expect_setequal(unique(ch4$thesis_tables$n_points), c(6, 15, 27, 54))
  rt <- ch4$runtime
  expect_setequal(unique(rt$n_points), c(6, 15, 27, 54))
  expect_true(all(c("seconds", "ratio_to_griddy", "ess_per_s") %in% names(rt)))
  expect_equal(as.vector(table(rt$method)), rep(4L, 5))
  expect_true(all(rt$seconds > 0))
})

test_that("koh_calibrate() reads a library on disk through the library interface", {
  skip_if_not_installed("RobustCalibration")
  skip_if_not_installed("hdf5r")
  toy <- koh_toy()
  file <- withr::local_tempfile(fileext = ".h5")
  disk <- write_library(toy$library, file)
  run <- function(lib) {
    koh_calibrate(lib, toy$field, discrepancy = "none", n_iter = 400, burn_in = 100,
                  tune_rounds = 0, seed = 2)
  }
  expect_identical(run(disk)$draws, run(toy$library)$draws)
})

test_that("a KOH summary prints each parameter on its own scale, within width", {
  set.seed(1)
  draws <- data.frame(iteration = 1:400, h = stats::rnorm(400, 1510, 30),
                      k = stats::runif(400, 0.4, 0.6), sigma2 = stats::rexp(400))
  koh <- structure(list(draws = draws, parameters = c("h", "k")), class = "griddy_koh")
  s <- summary(koh)
  expect_identical(s$estimate, s$mean)
  expect_identical(s$estimate_type, c("mean", "mean"))
  out <- utils::capture.output(print(s, width = 200))
  expect_false(any(grepl("e\\+", out)))
  expect_match(out, "^ +h +1[0-9]{3} +1[0-9]{3} +1[0-9]{3} ", all = FALSE)
  expect_match(out, "^ +k +0\\.[0-9]{4} +0\\.[0-9]{4} +0\\.[0-9]{4} ", all = FALSE)
  expect_match(out, "^estimate: posterior mean\\.$", all = FALSE)
  narrow <- utils::capture.output(print(s, width = 40))
  expect_lte(max(nchar(narrow)), 40)
  # a subset keeps its level: it printed "% equal-tailed intervals"
  sub <- utils::capture.output(print(summary(koh, level = 0.9)[1, ], width = 200))
  expect_match(sub[1], "90% equal-tailed intervals")
})

test_that("koh_calibrate() refuses a library too small for its emulator (it printed NaN warnings and a confident interval)", {
  skip_if_not_installed("RobustCalibration")
  toy <- koh_toy()
  for (n in 2:3) {
    small <- lib_rows(toy$library, c(1, 13, 25)[seq_len(n)])
    err <- expect_error(koh_calibrate(small, toy$field, discrepancy = "none", n_iter = 300,
                                      burn_in = 100, tune_iter = 100, seed = 1),
                        class = "griddy_error_library_size")
    expect_match(conditionMessage(err), paste0("at least 4 runs.*2 parameters.*has ", n, " runs"))
  }
})

test_that("koh_calibrate() says `progress`; `quiet` still works, with a deprecation warning", {
  skip_if_not_installed("RobustCalibration")
  toy <- koh_toy()
  expect_identical(formals(koh_calibrate)$progress, quote(control$progress))
  expect_identical(formals(griddy_control)$progress, quote(interactive()))
  expect_silent(a <- koh_calibrate(toy$library, toy$field, discrepancy = "none", n_iter = 300,
                                   burn_in = 100, tune_iter = 100, seed = 1, progress = FALSE))
  expect_warning(b <- koh_calibrate(toy$library, toy$field, discrepancy = "none", n_iter = 300,
                                    burn_in = 100, tune_iter = 100, seed = 1, quiet = TRUE),
                 "`quiet` is deprecated.*progress = FALSE", class = "griddy_warning_deprecated")
  expect_identical(b$draws, a$draws)
  expect_error(koh_calibrate(toy$library, toy$field, progress = NA), "`progress` must be TRUE or FALSE")
})

test_that("the sampler's NaN warnings become one classed warning; others pass", {
  expect_warning(out <- koh_numerics({
    for (i in 1:50) log(-1)
    7
  }), "non-finite values \\(NaN\\) 50 time\\(s\\)", class = "griddy_warning_koh_numerics")
  expect_identical(out, 7)
  expect_warning(koh_numerics(warning("something else")), "something else")
})

test_that("print.griddy_koh() and its summary's print are stable", {
  set.seed(1)
  draws <- data.frame(iteration = 1:400, h = stats::rnorm(400, 1510, 30),
                      k = stats::runif(400, 0.4, 0.6), sigma2 = stats::rexp(400))
  koh <- structure(list(draws = draws, parameters = c("h", "k"), discrepancy = "GaSP",
                        n_runs = 40L, control = list(n_iter = 1000L),
                        acceptance = c(theta = 0.31, kernel = 0.52),
                        runtime = c(tuning = 0.4, sampling = 1.5)), class = "griddy_koh")
  expect_snapshot(print(summary(koh), width = 80))
  expect_snapshot(print(koh), transform = scrub_print)
})

test_that("koh_calibrate() passes its settings to RobustCalibration: the draws of a direct call", {
  skip_if_not_installed("RobustCalibration")
  # (RobustCalibration's own emulator refuses an output constant over the runs)
  toy <- koh_toy(x = seq(0.1, 1, length.out = 8))
  theta <- as.matrix(lib_theta(toy$library))
  for (d in c("GaSP", "none")) {
    fit <- koh_calibrate(toy$library, toy$field, discrepancy = d, n_iter = 400, burn_in = 100,
                         proposal_sd = c(0.05, 0.08), kernel = "matern_3_2", seed = 7)
    # RobustCalibration on its own ppgasp emulator of the same runs (simul_type
    # 0), as its users call it, with the same proposal, start and lengths
    type <- if (d == "none") "no-discrepancy" else d
    direct <- withr::with_seed(7, utils::capture.output(out <- RobustCalibration::rcalibration(
      design = cbind(x = lib_x(toy$library)$x), observations = drop(toy$field$y), p_theta = 2,
      simul_type = 0, input_simul = theta, output_simul = as.matrix(lib_outputs(toy$library)),
      loc_index_emulator = 1:8,
      theta_range = t(apply(theta, 2, range)), S = 400, S_0 = 100,
      sd_proposal = c(0.05, 0.08, if (d != "none") c(0.25, 0.25)), discrepancy_type = type,
      kernel_type = "matern_3_2")))
    post <- as.matrix(out@post_sample)
    expect_equal(unname(as.matrix(fit$draws[c("a", "b")])), unname(post[, 1:2]),
                 tolerance = 1e-8)
    expect_equal(fit$draws$sigma2, post[, ncol(post)], tolerance = 1e-8)
  }
})

test_that("the math model is the emulator's mean, with no predict.ppgasp() per iteration", {
  skip_if_not_installed("RobustCalibration")
  toy <- koh_toy()
  em <- koh_emulator(as.matrix(lib_theta(toy$library)), lib_outputs(toy$library), TRUE)
  emulated <- list(design_gp = lib_design_emulator(emulated_toy_library(n_runs = 50)))
  d <- emulated_toy_design()
  by_theta <- list(design_gp = lib_design_emulator(emulated_library(d$theta, d$y, n_runs = 50,
                                                                    seed = 1)))
  expect_identical(by_theta$design_gp$mode, "theta")
  expect_identical(emulated$design_gp$mode, "joint")
  at <- rbind(c(1.3, 2.2), c(0.1, 2.9))
  for (e in list(em, emulated, by_theta)) {
    f <- koh_mean_function(e)
    th <- if (is.null(e$design_gp)) at else cbind(k = c(2.1, 1.2), c = c(0.3, 0.45))
    for (i in 1:2) {
      expect_equal(f(th[i, ]), as.vector(koh_emulate(e, th[i, , drop = FALSE])),
                   tolerance = 1e-6)
    }
  }
  # the sampler's iterations call no predict.ppgasp()
  lib <- emulated_toy_library(n_runs = 50)
  calls <- new.env()
  calls$n <- 0L
  count <- bquote(assign("n", .(calls)$n + 1L, envir = .(calls)))
  suppressMessages(trace("predict.ppgasp", count, print = FALSE, where = asNamespace("RobustGaSP")))
  on.exit(suppressMessages(untrace("predict.ppgasp", where = asNamespace("RobustGaSP"))))
  koh_calibrate(lib, emulated_toy_field(), discrepancy = "none", n_iter = 300, burn_in = 100,
                tune_rounds = 1, tune_iter = 100, seed = 1)
  koh_calibrate(toy$library, toy$field, discrepancy = "none", n_iter = 300, burn_in = 100,
                tune_rounds = 1, tune_iter = 100, seed = 1)
  expect_identical(calls$n, 0L)
})

test_that("koh_calibrate() takes equal replicates as RobustCalibration does (they were refused)", {
  skip_if_not_installed("RobustCalibration")
  toy <- koh_toy(x = seq(0.1, 1, length.out = 8))
  set.seed(9)
  truth <- toy$truth[["a"]] * sin(3 * lib_x(toy$library)$x) + toy$truth[["b"]] *
    lib_x(toy$library)$x^2
  reps <- matrix(truth + stats::rnorm(24, sd = 0.02), 8, 3)
  long <- field_data(as.vector(reps), x = data.frame(x = rep(lib_x(toy$library)$x, 3)))
  fit <- koh_calibrate(toy$library, long, discrepancy = "GaSP", n_iter = 400, burn_in = 100,
                       proposal_sd = c(0.05, 0.08), seed = 3)
  expect_equal(fit$y_field, rowMeans(reps))
  theta <- as.matrix(lib_theta(toy$library))
  utils::capture.output(out <- withr::with_seed(3, RobustCalibration::rcalibration(
    design = cbind(x = lib_x(toy$library)$x), observations = reps, p_theta = 2,
    simul_type = 0, input_simul = theta, output_simul = as.matrix(lib_outputs(toy$library)),
      loc_index_emulator = 1:8,
    theta_range = t(apply(theta, 2, range)), S = 400, S_0 = 100,
    sd_proposal = c(0.05, 0.08, 0.25, 0.25), discrepancy_type = "GaSP")))
  expect_equal(unname(as.matrix(fit$draws[c("a", "b")])),
               unname(as.matrix(out@post_sample)[, 1:2]), tolerance = 1e-8)
  # unequal replicates: RobustCalibration would drop their pure error
  uneven <- field_data(as.vector(reps)[-1], x = data.frame(x = rep(lib_x(toy$library)$x, 3)[-1]))
  expect_error(koh_calibrate(toy$library, uneven, discrepancy = "none"),
               "same number.*2, 3 per cell", class = "griddy_error_unsupported")
})
