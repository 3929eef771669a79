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

test_that("the refined library keeps the prior uniform over the base library's range", {
  toy <- refine_toy()
  refined <- refine(toy$fit, refine_sim, max_runs = 600, runs_per_round = 200, seed = 3)
  lib <- refined$library
  expect_s3_class(lib, "refined_library")
  w <- exp(griddy:::log_run_weights(NULL, lib))
  expect_equal(sum(w), 1)
  k <- lib_theta(lib)$k
  # the weighted runs integrate a smooth function against the uniform prior
  # on [1, 4] as well as the base grid does (its quadrature error is the
  # tolerance): the added runs' density does not bias the prior
  f <- function(k) sin(2 * k) + k^2 / 4
  exact <- integrate(f, 1, 4)$value / 3
  base_error <- abs(mean(f(seq(1, 4, by = 0.5))) - exact)
  expect_lt(abs(sum(w * f(k)) - exact), 2 * base_error + 0.01)
  # and weighs runs equally where one density holds: inside the last box
  last <- lib$rounds[[length(lib$rounds)]]$box
  inner <- Reduce(function(a, b) c(max(a[1], b[1]), min(a[2], b[2])),
                  lapply(lib$rounds, function(r) r$box[, 1]))
  inside <- k > inner[1] & k < inner[2]
  expect_gt(sum(inside), 10)
  expect_equal(min(w[inside]), max(w[inside]))
})

test_that("calibrate() on a refined library uses its prior weights", {
  toy <- refine_toy()
  refined <- refine(toy$fit, refine_sim, max_runs = 600, seed = 1)
  again <- posterior_exact(refined$library, toy$field)
  expect_equal(again$run, griddy:::exact_from_problem(refined)$run)
  expect_equal(again$log_evidence, griddy:::grid_posterior(refined)$log_evidence)
})

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

test_that("refine() runs the simulator on the workers of a future plan, same result", {
  skip_if_not_installed("future.apply")
  skip_on_cran()
  toy <- refine_toy()
  # a simulator as a user defines it, in the global environment: one defined
  # in the test's environment drags the attached package's environment to
  # the workers ("'package:griddy' may not be available when loading")
  sim <- refine_sim
  environment(sim) <- globalenv()
  sequential <- refine(toy$fit, sim, max_runs = 200, seed = 4)
  future::plan("multisession", workers = 2)
  on.exit(future::plan("sequential"), add = TRUE)
  parallel <- refine(toy$fit, sim, max_runs = 200, seed = 4)
  expect_identical(lib_theta(parallel$library), lib_theta(sequential$library))
  expect_equal(parallel$C, sequential$C)
})

test_that("a refined fit and its library print what was added", {
  toy <- refine_toy()
  refined <- refine(toy$fit, refine_sim, max_runs = 2000, seed = 1)
  out <- paste(capture.output(print(refined)), collapse = "\n")
  expect_match(out, "Refined: [0-9]+ simulator run\\(s\\) added in [0-9]+ round\\(s\\); stopped: resolved")
  lib_out <- paste(capture.output(print(refined$library)), collapse = "\n")
  expect_match(lib_out, "<refined_library> [0-9]+ runs of 1 parameter\\(s\\): 7 of the base library")
  expect_match(lib_out, "simulated, 0 predicted")
})

test_that("refine() without a simulator predicts runs and resolves the posterior", {
  toy <- refine_toy()
  refined <- refine(toy$fit, max_runs = 2000, seed = 1)
  expect_identical(refined$refinement$source, "emulator")
  expect_identical(refined$refinement$reason, "resolved")
  lib <- refined$library
  expect_true(all(lib$added$rel_var >= 0 & lib$added$rel_var <= 1))
  expect_false(is.null(lib$rounds[[1]]$error))
  tab <- resolution_limited(refined)
  reference <- refine_toy_reference(toy)
  expect_true(tab$lower <= toy$k && toy$k <= tab$upper)
  # the prediction error widens, never narrows, the interval the data allow
  expect_gt(tab$upper - tab$lower, 0.9 * diff(reference))
  expect_lt(tab$upper - tab$lower, 3 * diff(reference))
})

test_that("the prediction error in the likelihood is the Woodbury form of the full covariance", {
  toy <- refine_toy()
  refined <- refine(toy$fit, max_runs = 300, runs_per_round = 100, seed = 2)
  lib <- refined$library
  err <- lib$rounds[[1]]$error
  i <- which(lib$added$round == 1)[1:3]
  y <- toy$fit$y_field
  setup <- toy$fit$setup
  got <- emulated_quad_forms(lib$added$y[i, , drop = FALSE], y, setup, err, lib$added$rel_var[i],
                             1L, length(y))
  for (j in seq_along(i)) {
    V <- lib$added$rel_var[i[j]] * err$U %*% diag(err$lambda, length(err$lambda)) %*% t(err$U)
    S <- diag(length(y)) + V / err$noise_var
    r <- y - lib$added$y[i[j], ]
    expect_equal(got$C[j, 1], drop(t(r) %*% solve(S, r)), tolerance = 1e-8)
    expect_equal(got$logdet[j, 1], as.numeric(determinant(S)$modulus), tolerance = 1e-8)
  }
})

test_that("the folded misfit gives the exact Gamma-normal likelihood of the extra covariance", {
  prior <- list(shape = 2, rate = 0.5)
  C <- matrix(c(3, 7), 2, 1)
  extra <- matrix(c(0.4, 0), 2, 1)
  folded <- fold_extra_logdet(structure(C, extra_logdet = extra), prior, 10)
  direct <- -(prior$shape + 5) * log(prior$rate + C / 2) - extra / 2
  via_fold <- -(prior$shape + 5) * log(prior$rate + folded / 2)
  expect_equal(via_fold, direct)
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

test_that("refine() without a simulator says so when the library cannot predict itself", {
  sharp <- function(theta) {
    t <- seq(0, 1, length.out = 40)
    t(vapply(theta$k, function(k) sin(k^2 * t), numeric(40)))
  }
  theta <- data.frame(k = seq(1, 4, by = 0.5))
  lib <- sim_library(theta, sharp(theta))
  set.seed(3)
  field <- field_data(sharp(data.frame(k = 2.71)) + rnorm(40, sd = 0.01), t = lib$t)
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 500, burn_in = 100, seed = 1))
  expect_warning(refined <- refine(fit, max_runs = 600, seed = 1),
                 "times the noise", class = "griddy_warning_emulation")
  expect_gt(refined$refinement$emulation_error, 1)
  toy <- refine_toy()
  fine <- refine(toy$fit, max_runs = 2000, seed = 1)
  expect_lt(fine$refinement$emulation_error, 1)
})

test_that("a posterior cut off by the last round's box is not resolved and reaches beyond it", {
  # the bug of the vignette's trial 130: a round's box that missed the truth
  # kept the posterior against its edge, and later boxes grew only by a
  # quarter of the (tiny) posterior width, so refine() ended narrow and wrong
  toy <- refine_toy()                          # truth k = 2.23
  box <- rbind(2.26, 2.6)
  theta_new <- data.frame(k = seq(2.26, 2.6, length.out = 200))
  problem <- extend_problem(toy$fit, theta_new, refine_sim(theta_new),
                            list(box = box, n = 200L, source = "simulator", error = NULL),
                            NULL)
  state <- refine_state(problem)
  expect_lt(state$table$lower, 2.26 + 0.1 * 0.34)        # against the box's lower edge
  expect_equal(unname(truncated_sides(state)), matrix(c(TRUE, FALSE), 2, 1))
  next_box <- refine_box(state)
  expect_lte(next_box[1, 1], 2.26 - 0.34)                # a whole box width beyond
  refined <- refine(toy$fit, refine_sim, max_runs = 2000, seed = 1)
  tab <- resolution_limited(refined)
  expect_true(tab$lower <= toy$k && toy$k <= tab$upper)
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

test_that("refine() without a simulator applies the error model within each noise group", {
  toy <- refine_toy()
  groups <- rep(c("early", "late"), each = 20)
  fit <- suppressWarnings(calibrate(toy$lib, toy$field, n_iter = 1500, burn_in = 500, seed = 1,
                                    noise_groups = groups))
  emu <- refine(fit, max_runs = 300, runs_per_round = 100, seed = 2)
  expect_identical(grep("^tau", names(emu$draws), value = TRUE), c("tau_early", "tau_late"))
  lib <- emu$library
  err <- lib$rounds[[1]]$error
  expect_length(err$noise_var, 2)
  tab <- resolution_limited(emu)
  expect_true(tab$lower <= toy$k && toy$k <= tab$upper)
  # each group's form: the Woodbury form of its block, on its own noise variance
  i <- which(lib$added$round == 1)[1]
  f <- emulated_group_forms(lib$added$y[i, , drop = FALSE], emu$y_field, emu$setup, err,
                            lib$added$rel_var[i], 1L, 40L, 1L)
  V <- lib$added$rel_var[i] * err$U %*% diag(err$lambda, length(err$lambda)) %*% t(err$U)
  ld <- 0
  for (k in 1:2) {
    o <- which(groups == c("early", "late")[k])
    S <- diag(20) + V[o, o] / err$noise_var[k]
    r <- (emu$y_field - lib$added$y[i, ])[o]
    expect_equal(f$C[1, k], drop(t(r) %*% solve(S, r)), tolerance = 1e-8)
    ld <- ld + as.numeric(determinant(S)$modulus)
  }
  expect_equal(f$logdet, ld, tolerance = 1e-8)
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
