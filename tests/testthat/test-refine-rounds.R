test_that("refine() stops at max_runs and says so", {
  toy <- refine_toy()
  expect_warning(
    refined <- refine(toy$fit, refine_sim, max_runs = 50, runs_per_round = 25, seed = 1),
    "resolution", class = "griddy_warning_resolution")
  expect_identical(refined$refinement$reason, "max_runs")
  expect_identical(refined$refinement$runs_added, 50L)
  expect_identical(refined$refinement$rounds, 2L)
  expect_identical(lib_n_runs(refined$library), 7L + 50L)
})

test_that("refine() of a fit that ran out of runs carries on where it stopped", {
  toy <- refine_toy()
  expect_warning(
    short <- refine(toy$fit, refine_sim, max_runs = 25, runs_per_round = 25, seed = 1),
    class = "griddy_warning_resolution")
  expect_identical(short$refinement$reason, "max_runs")
  more <- refine(short, refine_sim, max_runs = 2000, seed = 2)
  expect_gt(lib_n_runs(more$library), lib_n_runs(short$library))
  expect_identical(more$refinement$reason, "resolved")
})

test_that("refine() adds the replicates' pure error to its new runs", {
  toy <- toy_replicates()
  sim <- function(theta) {
    t(vapply(theta$k, function(k) rep(sin(toy$t * k / 3), 3) * rep(toy$x$h, each = 5),
             numeric(15)))
  }
  fit <- without_resolution_warning(
    calibrate(toy$library, toy$field, n_iter = 500, burn_in = 100, seed = 1))
  ref <- suppressWarnings(refine(fit, simulator = sim, max_runs = 8, seed = 1))
  added <- seq(nrow(toy$Y) + 1L, lib_n_runs(ref$library))
  expect_gt(length(added), 0L)
  # each new run's C is its residual sum of squares over every measurement
  Y_new <- lib_outputs(ref$library, added)
  rss <- vapply(seq_along(added), function(j) {
    sum((toy$y_rep - matrix(Y_new[j, ], 3, byrow = TRUE)[toy$rows, ])^2, na.rm = TRUE)
  }, numeric(1))
  expect_equal(ref$C[added, 1], rss)
  expect_identical(ref$n_obs, 28L)
})

test_that("a simulator failing in round 2 leaves every finished run in e$fit, and refine(e$fit) carries on", {
  toy <- refine_toy()
  # rounds of 20 runs in 10 chunks of 2: call 14 is round 2's fourth chunk
  s <- refine_sim_failing(fail_at = 14L)
  e <- tryCatch(refine(toy$fit, s$sim, max_runs = 400, runs_per_round = 20, seed = 1),
                error = function(e) e)
  expect_s3_class(e, "griddy_error_simulator")
  expect_match(conditionMessage(e), "refine(e$fit, simulator)", fixed = TRUE)
  expect_match(conditionMessage(e$parent), "the solver diverged")
  fit <- e$fit
  expect_s3_class(fit, "griddy_fit")
  expect_match(conditionMessage(e$parent), "failed on 1 run")
  # round 1 (20 runs) and round 2 but the one run that fails alone: its
  # fourth chunk failed and was run again row by row
  expect_equal(lib_n_runs(fit$library), 7L + 20L + 19L)
  expect_equal(fit$refinement$runs_added, 39L)
  expect_equal(fit$refinement$reason, "stopped")
  theta_added <- lib_theta(fit$library)[-(1:7), , drop = FALSE]
  expect_setequal(theta_added$k, s$seen$k)
  expect_false(s$broken %in% theta_added$k)
  expect_equal(lib_outputs(fit$library, 8:46), refine_sim(theta_added))
  expect_equal(sapply(lib_rounds(fit$library), `[[`, "n"), c(20, 19))
  # carrying on adds runs; none of those already there is simulated again
  s2 <- refine_sim_failing()
  ref <- refine(fit, s2$sim, max_runs = 400, runs_per_round = 20, seed = 2)
  expect_false(any(s2$seen$k %in% theta_added$k))
  expect_true(all(theta_added$k %in% lib_theta(ref$library)$k))
  expect_equal(ref$refinement$reason, "resolved")
})

test_that("an interrupt of the simulator keeps the chunks that finished", {
  toy <- refine_toy()
  s <- refine_sim_failing(fail_at = 13L, fail = signal_interrupt)
  e <- tryCatch(refine(toy$fit, s$sim, max_runs = 400, runs_per_round = 20, seed = 1),
                error = function(e) e)
  expect_s3_class(e, "griddy_error_interrupted")
  expect_equal(lib_n_runs(e$fit$library), 7L + 20L + 4L)
  expect_equal(lib_theta(e$fit$library)$k[-(1:7)], s$seen$k)
})

test_that("a simulator failing on every run leaves the fit as it was", {
  toy <- refine_toy()
  failing <- function(theta) stop("no licence")
  e <- tryCatch(refine(toy$fit, failing, max_runs = 40, seed = 1), error = function(e) e)
  expect_s3_class(e, "griddy_error_simulator")
  expect_identical(e$fit, toy$fit)
})

test_that("posterior mass far from the last proposal asks for another round", {
  toy <- linear4_toy()
  state <- refine_state(toy$fit)
  state$table$limited[] <- FALSE
  state$far_mass <- 0
  expect_false(needs_round(state, NULL, FALSE))
  state$far_mass <- 2 * far_mass_tol
  expect_true(needs_round(state, NULL, FALSE))
})

test_that("a mode resting on too few effective runs asks for another round, and is named", {
  toy <- linear4_toy()
  state <- refine_state(toy$fit)
  state$table$limited[] <- FALSE
  state$far_mass <- 0
  needed <- attr(state$table, "runs")$needed
  at <- lib_theta(toy$fit$library)[1:2, ]
  state$modes <- data.frame(mass = c(0.7, 0.3), effective_runs = c(2 * needed, needed),
                            at = I(list(at[1, ], at[2, ])))
  expect_false(needs_round(state, NULL, FALSE))
  expect_identical(unresolved_modes(state), integer())
  state$modes$effective_runs[2] <- needed / 5
  expect_true(needs_round(state, NULL, FALSE))
  expect_identical(unresolved_modes(state), 2L)
  reason <- unresolved_mode_reasons(state)
  expect_length(reason, 1L)
  expect_match(reason, "holding 30% of the posterior", fixed = TRUE)
  expect_match(reason, paste0("(", needed, " needed)"), fixed = TRUE)
  expect_match(reason, paste0(names(at)[1], " = "), fixed = TRUE)
})
