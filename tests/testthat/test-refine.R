test_that("refine() with a simulator resolves a posterior that sat on one run", {
  toy <- refine_toy()
  exact <- griddy:::exact_from_problem(toy$fit)
  expect_gt(max(exact$run), 0.9)        # collapsed onto the run k = 2 or 2.5
  refined <- refine(toy$fit, refine_sim, max_runs = 2000, seed = 1)
  expect_s3_class(refined, "griddy_fit")
  expect_identical(refined$refinement$reason, "resolved")
  expect_identical(refined$refinement$source, "simulator")
  tab <- griddy:::resolution_table(griddy:::exact_from_problem(refined)$run,
                                   lib_theta(refined$library))
  expect_false(any(tab$limited))
  reference <- refine_toy_reference(toy)
  width <- diff(reference)
  expect_lt(abs(tab$lower - reference[1]), 0.25 * width)
  expect_lt(abs(tab$upper - reference[2]), 0.25 * width)
  expect_true(tab$lower <= toy$k && toy$k <= tab$upper)
})

test_that("refine() of a resolved fit returns it unchanged", {
  toy <- refine_toy()
  refined <- refine(toy$fit, refine_sim, max_runs = 2000, seed = 1)
  expect_message(again <- refine(refined, refine_sim, seed = 2),
                 class = "griddy_message_resolved")
  expect_identical(again, refined)
})

test_that("refine() is reproducible with a seed and with set.seed()", {
  toy <- refine_toy()
  a <- refine(toy$fit, refine_sim, max_runs = 300, seed = 5)
  b <- refine(toy$fit, refine_sim, max_runs = 300, seed = 5)
  expect_identical(lib_theta(a$library), lib_theta(b$library))
  expect_identical(a$draws, b$draws)
  set.seed(9)
  c1 <- refine(toy$fit, refine_sim, max_runs = 300)
  set.seed(9)
  c2 <- refine(toy$fit, refine_sim, max_runs = 300)
  expect_identical(c1$draws, c2$draws)
})

test_that("refine() passes ... to the simulator and refines a refined fit again", {
  toy <- refine_toy()
  scaled <- function(theta, amplitude) amplitude * refine_sim(theta)
  expect_warning(
    refined <- refine(toy$fit, scaled, max_runs = 100, runs_per_round = 100, amplitude = 1,
                      seed = 1),
    class = "griddy_warning_resolution")
  expect_identical(refined$refinement$reason, "max_runs")
  twice <- refine(refined, refine_sim, max_runs = 2000, seed = 2)
  expect_gt(lib_n_runs(twice$library), lib_n_runs(refined$library))
  expect_length(twice$library$rounds, twice$refinement$rounds + 1L)
})

test_that("refine() refuses bad input with classed errors", {
  toy <- refine_toy()
  expect_error(refine(list()), class = "griddy_error_input")
  expect_error(refine(toy$fit, "sim"), class = "griddy_error_input")
  expect_error(refine(toy$fit, refine_sim, max_runs = 0), class = "griddy_error_input")
  expect_error(refine(toy$fit, refine_sim, max_runs = 10, seed = 1,
                      runs_per_round = -1), class = "griddy_error_input")
  wrong_shape <- function(theta) refine_sim(theta)[, 1:10]
  expect_error(refine(toy$fit, wrong_shape, max_runs = 10, seed = 1),
               class = "griddy_error_shape")
  not_finite <- function(theta) {
    y <- refine_sim(theta)
    y[1, 1] <- NaN
    y
  }
  expect_error(refine(toy$fit, not_finite, max_runs = 10, seed = 1),
               class = "griddy_error_numeric")
  weighted <- suppressWarnings(calibrate(toy$lib, toy$field, n_iter = 200, burn_in = 50,
                                         run_weights = 1:7, seed = 1))
  expect_error(refine(weighted, refine_sim, max_runs = 10), class = "griddy_error_input")
})

test_that("refine() works on fits with missing field data, with and without a simulator", {
  toy <- refine_toy()
  y <- toy$field$y
  set.seed(5)
  y[sample(40, 10)] <- NA
  field <- field_data(y, t = toy$lib$t)
  fit <- suppressWarnings(calibrate(toy$lib, field, n_iter = 1500, burn_in = 500, seed = 1))
  sim <- refine(fit, simulator = refine_sim, max_runs = 400, seed = 1)
  expect_identical(sim$n_obs, 30L)
  tab <- resolution_limited(sim)
  expect_true(tab$lower <= toy$k && toy$k <= tab$upper)
  emu <- refine(fit, max_runs = 300, runs_per_round = 100, seed = 2)
  tab <- resolution_limited(emu)
  expect_true(tab$lower <= toy$k && toy$k <= tab$upper)
  # the prediction error over the observed points: the Woodbury form of the
  # observed block of the full covariance
  lib <- emu$library
  err <- lib$rounds[[1]]$error
  i <- which(lib$added$round == 1)[1:2]
  got <- emulated_quad_forms(lib$added$y[i, , drop = FALSE], emu$y_field, emu$setup, err,
                             lib$added$rel_var[i], 1L, 40L)
  o <- which(!is.na(y))
  for (j in seq_along(i)) {
    V <- lib$added$rel_var[i[j]] * err$U %*% diag(err$lambda, length(err$lambda)) %*% t(err$U)
    S <- (diag(40) + V / err$noise_var)[o, o]
    r <- (emu$y_field - lib$added$y[i[j], ])[o]
    expect_equal(got$C[j, 1], drop(t(r) %*% solve(S, r)), tolerance = 1e-8)
    expect_equal(got$logdet[j, 1], as.numeric(determinant(S)$modulus), tolerance = 1e-8)
  }
})

test_that("the posterior noise variance is the exact posterior mean of 1/tau, column by column", {
  toy <- toy_ar1(n_runs = 40, n_t = 15)
  fit <- suppressWarnings(calibrate(toy$library, toy$field, rho_t = c(0, 0.3, 0.6),
                                    n_iter = 500, burn_in = 100, seed = 1))
  state <- refine_state(fit)
  pr <- state$problem
  n <- sum(pr$setup$group_sizes)
  # E[1/tau | i, g] = (b + C_ig / 2) / (a + n/2 - 1), averaged over the joint posterior
  expected <- sum(state$joint * (pr$prior$rate + pr$C / 2)) / (pr$prior$shape + n / 2 - 1)
  expect_equal(posterior_noise_var(state), expected, tolerance = 1e-12)
})

test_that("rounds of a proposal are 50 runs per parameter; boxes keep their doubling", {
  theta <- data.frame(a = 1:3, b = 1:3, c = 1:3, d = 1:3, e = 1)
  expect_equal(default_runs_per_round(theta), 800)
  expect_identical(default_runs_per_round(theta, proposals = TRUE), 200L)
  expect_equal(default_runs_per_round(theta[1:2], proposals = TRUE), 200)
  # predicted runs (no simulator) follow the proposal too, 200 a parameter
  expect_identical(default_runs_per_round(theta, predicted = TRUE), 800L)
  expect_equal(default_runs_per_round(theta[1:2], predicted = TRUE), 200)
})
