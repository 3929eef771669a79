# Every route that returns a griddy_fit runs finish_fit()'s checks: one test
# per route (calibrate(), refine() without and with a simulator).

# The warnings of `code` (muffled), and its value.
with_warnings <- function(code) {
  warnings <- list()
  value <- withCallingHandlers(code, warning = function(w) {
    warnings[[length(warnings) + 1L]] <<- w
    invokeRestart("muffleWarning")
  })
  list(value = value, classes = unlist(lapply(warnings, class)))
}

# The AR(1) toy of test-convergence.R on a coarse library: the thesis's
# update sticks on one rho grid point (see ?calibrate), and the posterior is
# not resolved, so refine() has runs to add.
stuck_toy <- function() toy_ar1(n_runs = 15, n_t = 60, lag_cor = 0.9)

test_that("calibrate() finishes its fit: checks stored, warnings given", {
  toy <- stuck_toy()
  out <- with_warnings(calibrate(toy$library, toy$field, rho_t = c(0, 0.3, 0.6, 0.9),
                                 n_iter = 1000, burn_in = 200, chains = 2,
                                 update = "thesis", seed = 26))
  expect_true("griddy_warning_convergence" %in% out$classes)
  expect_true("griddy_warning_resolution" %in% out$classes)
  expect_false(is.null(out$value$gap_screen))
  expect_gt(out$value$runtime[["checks"]], 0)
})

test_that("refine() without a simulator warns of chains stuck on one rho grid point", {
  toy <- stuck_toy()
  fit <- suppressWarnings(calibrate(toy$library, toy$field, rho_t = c(0, 0.3, 0.6, 0.9),
                                    n_iter = 1000, burn_in = 200, chains = 2,
                                    update = "thesis", seed = 26))
  for (seed in 1:2) {
    out <- with_warnings(refine(fit, max_runs = 100, seed = seed))
    refined <- out$value
    expect_s3_class(refined$library, "refined_library")
    # the chains stuck: the draws far from the exact posterior over runs
    a <- attr(summary(refined), "adequacy")
    stuck <- tv_beyond_reference(a$tv_distance, a$tv_reference) ||
      any(refined$diagnostics$rhat > rhat_threshold, na.rm = TRUE)
    expect_true(stuck)
    expect_true("griddy_warning_convergence" %in% out$classes)
    # refine()'s own resolution warning, once, and no calibrate() one beside it
    expect_lte(sum(out$classes == "griddy_warning_resolution"), 1L)
    expect_false(is.null(refined$gap_screen))
  }
})

test_that("refine() with a simulator screens the refined fit for a gap and warns of it", {
  # screen_system() (test-gap-screen.R's) on a coarse library: the fit is
  # limited by its resolution, so calibrate() gives no gap warning; refined,
  # the gap shows
  theta <- data.frame(a = seq(1, 2, length.out = 21))
  x <- data.frame(load = c(1, 2, 3))
  t <- seq(0, 1, length.out = 12)
  sim <- function(theta) {
    t(vapply(theta$a, function(a) unlist(lapply(x$load, function(l) a * l * exp(-0.4 * t))),
             numeric(36)))
  }
  set.seed(1)
  mu <- sim(data.frame(a = 1.5))[1, ] + 0.1 * rep(x$load, each = length(t))^2 * t^2
  field <- field_data(matrix(mu + stats::rnorm(36, sd = 0.05), 3, 12, byrow = TRUE),
                      x = x, t = t)
  first <- with_warnings(calibrate(sim_library(theta, sim(theta), x = x, t = t), field,
                                   n_iter = 300, burn_in = 100, seed = 1))
  expect_false("griddy_warning_gap" %in% first$classes)
  out <- with_warnings(refine(first$value, sim, max_runs = 400, seed = 1))
  expect_identical(out$value$refinement$reason, "resolved")
  expect_gt(out$value$gap_screen$log_bf, gap_detect_log_odds)
  expect_true("griddy_warning_gap" %in% out$classes)
})

test_that("the fit an error of refine() carries is finished, without warnings", {
  toy <- refine_toy()
  failing <- refine_sim_failing(fail_at = 2L)
  err <- expect_error(suppressWarnings(refine(toy$fit, failing$sim, max_runs = 400,
                                              runs_per_round = 50, seed = 1)),
                      class = "griddy_error_simulator")
  expect_s3_class(err$fit, "griddy_fit")
  expect_false(is.null(err$fit$gap_screen))
})
