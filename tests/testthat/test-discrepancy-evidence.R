# A 2-parameter library on a 21 x 21 grid, 3 loads x 12 outputs; the truth
# between the runs, and a gap growing with load and t when `bump` > 0.
gap_system <- function(bump, seed, reps = 1) {
  load_decay_system(function(l, t) l^2 * t^2, bump, n_grid = 21, n_t = 12,
                    truth = c(1.525, 0.4125), seed = seed, reps = reps)
}

test_that("the Bayes factor favours a discrepancy with a gap and not without", {
  for (reps in c(1, 3)) {
    none <- gap_system(0, seed = 2, reps = reps)
    gap <- gap_system(0.1, seed = 2, reps = reps)
    fit_none <- suppressWarnings(calibrate(none$library, none$field, n_iter = 300,
                                           burn_in = 100, seed = 1,
                                           discrepancy = gp_discrepancy()))
    ev_gap <- discrepancy_evidence(posterior_exact(gap$library, gap$field,
                                                   discrepancy = gp_discrepancy()))
    expect_gt(ev_gap$log_bayes_factor, log(20))
    expect_true(is.finite(ev_gap$log_bayes_factor))
    # the truth lies between the runs, and at this library's spacing the
    # misfit between them looks like a gap; refined where the posterior is,
    # the evidence goes against one
    refined <- suppressWarnings(refine(fit_none, none$simulator, seed = 1))
    expect_lt(discrepancy_evidence(refined)$log_bayes_factor, 0)
  }
})

test_that("the Bayes factor is the ratio of the two models' exact evidences", {
  sys <- gap_system(0.05, seed = 4)
  disc <- gp_discrepancy(ratio = c(0, 1, 10), length_x = 1, length_t = c(0.3, 1))
  ev <- discrepancy_evidence(posterior_exact(sys$library, sys$field, discrepancy = disc))
  z0 <- posterior_exact(sys$library, sys$field, discrepancy = gp_discrepancy(ratio = 0))
  z1 <- posterior_exact(sys$library, sys$field,
                        discrepancy = gp_discrepancy(ratio = c(1, 10), length_x = 1,
                                                     length_t = c(0.3, 1)))
  expect_equal(ev$log_bayes_factor, z1$log_evidence - z0$log_evidence, tolerance = 1e-8)
  # and logLik() of the fit with the discrepancy mixes them by the prior
  both <- posterior_exact(sys$library, sys$field, discrepancy = disc)
  expect_equal(both$log_evidence,
               log(0.5 * exp(z0$log_evidence) + 0.5 * exp(z1$log_evidence)), tolerance = 1e-8)
})

test_that("calibrate() warns of a gap, and summary() says what theta then is", {
  sys <- gap_system(0.1, seed = 2)
  gap_warning <- NULL
  fit <- withCallingHandlers(
    calibrate(sys$library, sys$field, n_iter = 300, burn_in = 100, seed = 1,
              discrepancy = gp_discrepancy()),
    warning = function(w) {
      if (inherits(w, "griddy_warning_gap")) gap_warning <<- w
      invokeRestart("muffleWarning")
    })
  expect_s3_class(gap_warning, "griddy_warning_gap")
  out <- paste(capture.output(print(summary(fit), width = 1000)), collapse = " ")
  expect_match(out, "Discrepancy: log Bayes factor", fixed = TRUE)
  # the default discrepancy is orthogonal: theta is the L2 projection
  estimand <- theta_estimand(gp_discrepancy())
  expect_match(conditionMessage(gap_warning), estimand, fixed = TRUE)
  expect_match(out, estimand, fixed = TRUE)
  ev <- discrepancy_evidence(fit)
  expect_s3_class(ev, "griddy_discrepancy_evidence")
  expect_equal(sum(ev$ratio$prob), 1)
  expect_snapshot(print(structure(list(log_bayes_factor = 3.2, prob_none = 0.04,
                                       prior_none = 0.5,
                                       ratio = data.frame(ratio = c(0, 1), prob = c(0.04, 0.96))),
                                  class = "griddy_discrepancy_evidence")))
})

test_that("a gap warning under knowledge of the gap calls theta physical as far as it holds", {
  # issue 33: the warning said "not the physical one" whatever the
  # discrepancy, though zero_at and flat_at are what make theta physical
  sys <- gap_system(0.1, seed = 2)
  known <- gp_discrepancy(zero_at = data.frame(load = c(1, 2, 3), t = 0))
  expect_warning(
    fit <- suppressWarnings(calibrate(sys$library, sys$field, n_iter = 300, burn_in = 100,
                                      seed = 1, discrepancy = known),
                            classes = "griddy_warning_resolution"),
    theta_estimand(known), fixed = TRUE, class = "griddy_warning_gap")
  expect_match(theta_estimand(known), "physical value to the extent that the knowledge holds",
               fixed = TRUE)
  out <- paste(capture.output(print(fit, width = 1000)), collapse = " ")
  expect_match(out, theta_estimand(known), fixed = TRUE)
  expect_no_match(out, "not the physical one", fixed = TRUE)
})

test_that("discrepancy_evidence() needs a discrepancy with ratio 0 and positive ratios", {
  sys <- gap_system(0, seed = 1)
  expect_error(discrepancy_evidence(posterior_exact(sys$library, sys$field)),
               class = "griddy_error_input")
  expect_error(discrepancy_evidence(posterior_exact(sys$library, sys$field,
                                                    discrepancy = gp_discrepancy(ratio = 1))),
               class = "griddy_error_input")
  expect_error(discrepancy_evidence(1), class = "griddy_error_input")
})
