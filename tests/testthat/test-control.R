test_that("griddy_control() holds validated whole numbers and a flag", {
  control <- griddy_control(n_iter = 400, burn_in = 100, thin = 3, chains = 2,
                            max_runs = 50, runs_per_round = 10, progress = FALSE)
  expect_s3_class(control, "griddy_control")
  expect_identical(control$n_iter, 400L)
  expect_identical(control$burn_in, 100L)
  expect_identical(control$thin, 3L)
  expect_identical(control$chains, 2L)
  expect_identical(control$max_runs, 50L)
  expect_identical(control$runs_per_round, 10L)
  expect_false(control$progress)
  expect_null(griddy_control()$runs_per_round)
})

test_that("griddy_control() refuses settings that keep no draw, with classed errors", {
  expect_error(griddy_control(n_iter = 100, burn_in = 100), "smaller than `n_iter`",
               class = "griddy_error_input")
  expect_error(griddy_control(n_iter = 100, burn_in = 50, thin = 60), "keeps no draw",
               class = "griddy_error_input")
  expect_error(griddy_control(max_runs = 0), "max_runs", class = "griddy_error_input")
  expect_error(griddy_control(progress = NA), "progress", class = "griddy_error_input")
  expect_error(griddy_control(chains = 1.5), "chains", class = "griddy_error_input")
})

test_that("assert_control() names what it received", {
  expect_error(assert_control(list(n_iter = 10)), "griddy_control\\(\\); received list",
               class = "griddy_error_input")
})

test_that("print.griddy_control() shows every setting", {
  expect_snapshot(print(griddy_control(n_iter = 4000, burn_in = 1000, chains = 2,
                                       progress = FALSE)))
  expect_snapshot(print(griddy_control(runs_per_round = 25, progress = FALSE)))
})

test_that("refine() and koh_calibrate() take their defaults from `control`", {
  expect_error(refine(list(), control = list()), "griddy_control", class = "griddy_error_input")
  expect_error(koh_calibrate(NULL, NULL, control = "fast"), "griddy_control",
               class = "griddy_error_input")
  # an argument given in the call wins over the control's field
  expect_identical(formals(refine)$max_runs, quote(control$max_runs))
  fit <- refine_toy()$fit
  few <- suppressWarnings(refine(fit, refine_sim, seed = 1,
                                 control = griddy_control(max_runs = 20, progress = FALSE)))
  expect_lte(few$refinement$runs_added, 20L)
  more <- suppressWarnings(refine(fit, refine_sim, seed = 1, max_runs = 40,
                                  control = griddy_control(max_runs = 20, progress = FALSE)))
  expect_gt(more$refinement$runs_added, 20L)
})

test_that("calibrate(control =) gives the draws of the same settings given one by one", {
  toy <- toy_ar1(n_runs = 60, n_t = 10)
  # AR(1) noise fitted as independent: the gap screen says so, rightly
  calibrate <- function(...) suppressWarnings(griddy::calibrate(...), classes = "griddy_warning_gap")
  by_args <- calibrate(toy$library, toy$field, n_iter = 600, burn_in = 100, chains = 2,
                       seed = 3, progress = FALSE)
  by_control <- calibrate(toy$library, toy$field, seed = 3,
                          control = griddy_control(n_iter = 600, burn_in = 100, chains = 2,
                                                   progress = FALSE))
  expect_identical(by_control$draws, by_args$draws)
  expect_identical(by_control$control, by_args$control)
  # an argument given in the call wins
  mixed <- calibrate(toy$library, toy$field, n_iter = 800, seed = 3,
                     control = griddy_control(n_iter = 600, burn_in = 100, progress = FALSE))
  expect_identical(mixed$control$n_iter, 800L)
  expect_error(calibrate(toy$library, toy$field, control = griddy_control), "griddy_control",
               class = "griddy_error_input")
})

test_that("a default collapsed chain is sized to the problem, and run in full when it has not settled", {
  toy <- toy_ar1(n_runs = 200, n_t = 30, sd = 0.3, lag_cor = 0)
  fit <- suppressWarnings(calibrate(toy$library, toy$field, seed = 1), classes = "griddy_warning_gap")
  expect_identical(c(fit$control$n_iter, fit$control$burn_in),
                   c(sized_chain$n_iter, sized_chain$burn_in))
  expect_identical(nrow(fit$draws), sized_chain$n_iter - sized_chain$burn_in)
  expect_true(chain_settled(fit))
  full <- suppressWarnings(calibrate(toy$library, toy$field, seed = 1, n_iter = 35000,
                                     burn_in = 15000), classes = "griddy_warning_gap")
  expect_identical(full$control$n_iter, 35000L)
  # a length given, here or in griddy_control(), or the thesis's update, runs as given
  given <- suppressWarnings(calibrate(toy$library, toy$field, seed = 1, burn_in = 15000),
                            classes = "griddy_warning_gap")
  expect_identical(given$control$n_iter, 35000L)
  expect_false(griddy_control(n_iter = 35000)$sized)
  expect_true(griddy_control(chains = 2)$sized)
  # too few effective draws: not settled (200 draws, fewer than 400)
  short <- suppressWarnings(calibrate(toy$library, toy$field, seed = 1, n_iter = 300,
                                      burn_in = 100), classes = "griddy_warning_gap")
  expect_false(chain_settled(short))
  expect_lt(short$diagnostics$effective_draws, sized_min_effective)
})

test_that("a sized chain that has not settled runs again at the full length", {
  toy <- toy_ar1(n_runs = 200, n_t = 30, sd = 0.3, lag_cor = 0)
  problem <- local_problem(toy$library, toy$field)
  control <- sampler_control(3000, 1000, 1, 1, FALSE)
  # a first run of 200 kept draws has fewer than 400 effective ones
  fit <- sample_sized(problem, "collapsed", control, seed = 1, call = NULL,
                      start = proc.time()[["elapsed"]], first = list(n_iter = 300L, burn_in = 100L))
  expect_identical(fit$control$n_iter, 3000L)
  expect_identical(nrow(fit$draws), 2000L)
  expect_identical(fit$draws, sample_problem(problem, "collapsed", control, 1, NULL)$draws)
  # one that has settled is kept
  kept <- sample_sized(problem, "collapsed", control, seed = 1, call = NULL,
                       start = proc.time()[["elapsed"]], first = list(n_iter = 1500L, burn_in = 500L))
  expect_identical(kept$control$n_iter, 1500L)
})
