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

test_that("refine() without a simulator says so when the library cannot predict itself", {
  fit <- sharp_fit()
  # (its misfit shows as a gap too: test-gap-screen.R)
  expect_warning(refined <- suppressWarnings(refine(fit, max_runs = 600, seed = 1),
                                             classes = "griddy_warning_gap"),
                 "times the noise", class = "griddy_warning_emulation")
  expect_gt(refined$refinement$emulation_error, 1)
  toy <- refine_toy()
  fine <- refine(toy$fit, max_runs = 2000, seed = 1)
  expect_lt(fine$refinement$emulation_error, 1)
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

test_that("refine(fit, simulator) on an emulated library simulates the predicted runs near the posterior", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 1000)
  field <- emulated_toy_field(sd = 0.1)
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 1000, burn_in = 200, seed = 1))
  # the fit counts as resolved on its predicted runs
  expect_true(is_resolved(refine_state(fit)$table, NULL))
  calls <- 0L
  sim <- function(theta) {
    calls <<- calls + 1L
    emulated_truth(as.matrix(theta))
  }
  ref <- suppressWarnings(refine(fit, sim, max_runs = 2000, seed = 1))
  expect_gt(calls, 0L)
  library <- ref$library
  replaced <- library$replaced$rows
  expect_gt(length(replaced), 0L)
  # the replaced runs keep their theta and now hold the simulator's outputs
  expect_equal(lib_theta(library)[replaced, ], lib_theta(lib)[replaced, ], ignore_attr = TRUE)
  expect_equal(lib_outputs(library, replaced),
               emulated_truth(as.matrix(lib_theta(library)[replaced, ])), ignore_attr = TRUE)
  expect_false(any(lib_predicted(library)[replaced]))
  # resolution is judged on simulated runs
  state <- refine_state(ref)
  expect_lte(predicted_mass(state), predicted_tol)
  # calibrate() on the refined library gives the posterior refine() had
  expect_equal(posterior_exact(library, field)$run, state$p, tolerance = 1e-8)
  s <- summary(ref)
  expect_true(s$lower[s$parameter == "k"] < 2.1 && s$upper[s$parameter == "k"] > 2.1)
  expect_true(s$lower[s$parameter == "c"] < 0.3 && s$upper[s$parameter == "c"] > 0.3)
})

test_that("an emulator that cannot be built is said in terms of the refine() call", {
  toy <- refine_toy()
  state <- refine_state(toy$fit)
  # a box beyond the library's range (k in 1..4): the emulator's region is empty
  e <- tryCatch(round_emulator(state, rbind(5, 6)), error = function(e) e)
  expect_s3_class(e, "griddy_error_emulation")
  expect_no_match(conditionMessage(e), "region")
  expect_match(conditionMessage(e), "refine() without a simulator", fixed = TRUE)
})

# A smooth p-parameter system on [0, 1]^p (bench/many-parameters-systems.R's
# smooth-p, 30 outputs): its Latin hypercube library of n runs and field
# data at an inner truth.
nosim_system <- function(p, n, sd = 0.05, seed = 1) {
  set.seed(240 + p)
  G <- matrix(stats::rnorm(30 * p), 30, p)
  H <- matrix(stats::rnorm(30 * p), 30, p)
  sim <- function(theta) {
    th <- as.matrix(theta)
    sin(pi * th %*% t(G)) + 0.5 * exp(th %*% t(H) / 2)
  }
  set.seed(seed)
  theta <- latin_hypercube(n, rbind(rep(0, p), rep(1, p)), paste0("th", seq_len(p)))
  lib <- sim_library(theta, sim(theta))
  truth <- stats::runif(p, 0.3, 0.7)
  field <- field_data(sim(matrix(truth, 1)) + stats::rnorm(30, sd = sd), t = lib$t)
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 1000, burn_in = 200, seed = 1))
  list(fit = fit, truth = truth, p = p)
}

test_that("refine() without a simulator resolves four parameters by the proposal's rounds", {
  skip_if_not_installed("RobustGaSP")
  sys <- nosim_system(4, 300, sd = 0.15)
  refined <- refine(sys$fit, max_runs = 8000, seed = 1)
  expect_identical(refined$refinement$reason, "resolved")
  rounds <- refined$library$rounds
  # the rounds follow the posterior (a box's hypercube held 4 parameters
  # on too few effective runs: issue 35)
  expect_true(all(vapply(rounds, function(r) !is.null(r$proposal) && is.null(r$box),
                         logical(1))))
  expect_true(all(vapply(rounds, function(r) !is.null(r$error), logical(1))))
  expect_equal(rounds[[1]]$n, predicted_round_per_parameter * 4)
  tab <- resolution_limited(refined)
  expect_true(attr(tab, "runs")$resolved)
  expect_gte(sum(tab$lower <= sys$truth & sys$truth <= tab$upper), 3)
})

test_that("refine() without a simulator says an under-resourced 8-parameter fit is not resolved", {
  skip_if_not_installed("RobustGaSP")
  sys <- nosim_system(8, 150)
  expect_warning(refined <- suppressWarnings(refine(sys$fit, max_runs = 1600, seed = 1),
                                             classes = c("griddy_warning_emulation",
                                                         "griddy_warning_gap",
                                                         "griddy_warning_convergence")),
                 "before the posterior was resolved", class = "griddy_warning_resolution")
  expect_identical(refined$refinement$reason, "max_runs")
  expect_false(attr(resolution_limited(refined), "runs")$resolved)
})

test_that("the proposal rounds' emulator scales its error to its leave-one-out variance", {
  skip_if_not_installed("RobustGaSP")
  sys <- nosim_system(4, 120)
  state <- refine_state(sys$fit)
  em <- proposal_round_emulator(state)
  expect_identical(em$method, "gp")
  expect_equal(em$var_max, mean(ppgasp_loo(em$fit, em$vary, length(em$rows))$var))
  # over the whole range, on every run
  expect_equal(unname(em$refine_region), unname(library_box(lib_base(sys$fit$library))))
  expect_length(em$rows, 120L)
})
