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

test_that("a refined fit and its library print what was added", {
  toy <- refine_toy()
  refined <- refine(toy$fit, refine_sim, max_runs = 2000, seed = 1)
  out <- paste(capture.output(print(refined)), collapse = "\n")
  expect_match(out, "Refined: [0-9]+ simulator run\\(s\\) added in [0-9]+ round\\(s\\); stopped: resolved")
  lib_out <- paste(capture.output(print(refined$library)), collapse = "\n")
  expect_match(lib_out, "<refined_library> [0-9]+ runs of 1 parameter\\(s\\): 7 of the base library")
  expect_match(lib_out, "simulated, 0 predicted")
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

test_that("predicted runs' forms are their emulated forms alone, no plain forms beside them", {
  toy <- refine_toy()
  lib <- refine(toy$fit, max_runs = 300, runs_per_round = 100, seed = 2)$library
  y <- toy$fit$y_field
  setup <- toy$fit$setup
  i <- which(lib$added$round == 1)[1:4]
  err <- lib$rounds[[1]]$error
  expect_false(is.null(err))
  calls <- new.env()
  calls$plain <- 0L
  ns <- environment(added_quad_forms)
  suppressMessages(trace("plain_quad_forms", quote(calls$plain <- calls$plain + 1L),
                         print = FALSE, where = ns))
  withr::defer(suppressMessages(untrace("plain_quad_forms", where = ns)))
  got <- added_quad_forms(lib, i, y, setup)
  expect_identical(calls$plain, 0L)
  want <- emulated_quad_forms(lib$added$y[i, , drop = FALSE], y, setup, err, lib$added$rel_var[i],
                              1L, length(y))
  expect_identical(got$C, want$C)
  expect_identical(got$extra_logdet, want$logdet)
})

test_that("the folded misfit gives the exact Gamma-normal likelihood of the extra covariance", {
  prior <- list(shape = 2, rate = 0.5)
  C <- matrix(c(3, 7), 2, 1)
  extra <- matrix(c(0.4, 0), 2, 1)
  folded <- fold_extra_logdet(list(C = C, extra_logdet = extra), prior, 10)
  direct <- -(prior$shape + 5) * log(prior$rate + C / 2) - extra / 2
  via_fold <- -(prior$shape + 5) * log(prior$rate + folded / 2)
  expect_equal(via_fold, direct)
})

test_that("print.refined_library() shows the base, the rounds and the runs added", {
  toy <- refine_toy()
  refined <- suppressWarnings(refine(toy$fit, refine_sim, max_runs = 40, seed = 1,
                                     progress = FALSE))
  expect_snapshot(print(refined$library))
})

test_that("a refined library over an emulated one keeps the base's error and plug-in in C's results", {
  skip_if_not_installed("RobustGaSP")
  # they travelled as attributes of C, which rbind() of the base's and the
  # added runs' forms dropped: calibrate() on such a library lost the
  # emulation error its summary reports
  lib <- emulated_toy_library(n = 40, n_runs = 300)
  field <- emulated_toy_field()
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 300, burn_in = 100, seed = 1))
  refined <- suppressWarnings(refine(fit, max_runs = 100, runs_per_round = 100, seed = 1))
  forms <- lib_quad_forms(refined$library, refined$y_field, refined$setup)
  expect_true(is.finite(forms$emulation_error))
  expect_identical(forms$plug_in$y_field, refined$y_field)
  again <- suppressWarnings(calibrate(refined$library, field, n_iter = 300, burn_in = 100,
                                      seed = 1))
  expect_equal(again$emulation_error, forms$emulation_error)
  expect_equal(again$C, refined$C)
})

test_that("a problem is classed, holds its prior once and C bare", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n = 40, n_runs = 300)
  problem <- suppressWarnings(local_problem(lib, emulated_toy_field(), rho_t = c(0, 0.5)))
  expect_s3_class(problem, "griddy_problem")
  # the setup carries the problem's prior, the same object, once
  expect_identical(problem$setup$fold_prior, problem$prior)
  expect_null(problem$setup$noise_prior)
  expect_named(attributes(problem$C), "dim")
  expect_true(is.finite(problem$emulation_error))
  expect_identical(problem$library$noise$y_field, problem$y_field)
})
