# diagnose_gap() without candidates (gap-discrepancy.R).

# a small discrepancy grid keeps these tests fast
small_disc <- function() gp_discrepancy(ratio = c(0, 1, 10, 100), length_x = c(0.3, 1),
                                        length_t = c(0.1, 0.3))

test_that("without candidates the evidence is the exact Bayes factor of the fit with a discrepancy", {
  toy <- toy_gap(0.2)
  d <- small_disc()
  gap <- diagnose_gap(toy$fit, discrepancy = d, max_runs = 0)
  exact <- posterior_exact(toy$lib, toy$field, discrepancy = d)
  ev <- discrepancy_evidence(exact)
  log_ev <- stats::setNames(gap$which$log_evidence, gap$which$effect)
  expect_equal(log_ev[["other"]] - log_ev[["none"]], ev$log_bayes_factor, tolerance = 1e-10)
  expect_equal(gap$evidence$log_bayes_factor, ev$log_bayes_factor, tolerance = 1e-10)
  # equal model priors: P(other) is the Bayes factor's odds
  expect_equal(gap$which$prob[gap$which$effect == "other"], plogis(ev$log_bayes_factor),
               tolerance = 1e-10)
  # NULL, missing and an empty list are the same question
  expect_equal(diagnose_gap(toy$fit, list(), discrepancy = d, max_runs = 0)$which, gap$which)
  expect_equal(diagnose_gap(toy$fit, NULL, discrepancy = d, max_runs = 0)$which, gap$which)
})

test_that("a withheld effect answers 'other' and the null 'none', on and off the runs", {
  d <- small_disc()
  effect <- diagnose_gap(toy_gap(0.3)$fit, discrepancy = d, seed = 1)
  expect_identical(effect$verdict$answer, "other")
  expect_gt(effect$evidence$log_bayes_factor, log(20))
  expect_true(any(effect$where$flagged))
  # truth on a run (a = 1) and half-way between two runs of a coarse library
  for (a in c(1, 1.05)) {
    null <- toy_gap(0, a_true = a, a_grid = seq(0.5, 1.5, length.out = 11))
    gap <- diagnose_gap(null$fit, discrepancy = d, seed = 1)
    expect_identical(gap$verdict$answer, "none")
    expect_false(any(gap$where$flagged))
    expect_lt(gap$which$prob[gap$which$effect == "other"], 0.5)
  }
})

test_that("inconclusive evidence for a discrepancy answers 'none', with no block flagged", {
  toy <- toy_gap(0.2)
  d <- small_disc()
  # with noise groups there is no leave-block-out check: the evidence alone
  fit <- suppressWarnings(calibrate(toy$lib, toy$field, n_iter = 200, burn_in = 50, seed = 1,
                                    noise_groups = "x"))
  gap <- diagnose_gap(fit, discrepancy = d, max_runs = 0)
  log_bf <- gap$evidence$log_bayes_factor
  expect_gt(log_bf, 1)
  # prior odds that leave posterior log odds of 0.5 for "other": more
  # probable than "none", but inconclusive
  odds <- diagnose_gap(fit, discrepancy = d, max_runs = 0,
                       prior_models = c(none = exp(log_bf - 0.5), other = 1))
  expect_equal(odds$which$effect[1], "other")
  expect_identical(odds$verdict$answer, "none")
  expect_identical(odds$verdict$reason, "inconclusive")
  expect_false(any(odds$where$flagged))
  expect_match(capture.output(print(odds))[2], "inconclusive")
  # log odds of 1.5: a gap
  found <- diagnose_gap(fit, discrepancy = d, max_runs = 0,
                        prior_models = c(none = exp(log_bf - 1.5), other = 1))
  expect_identical(found$verdict$answer, "other")
})

test_that("a gap the evidence calls inconclusive but the base model's checks flag is 'other'", {
  toy <- toy_gap(0.2)
  d <- small_disc()
  log_bf <- diagnose_gap(toy$fit, discrepancy = d, max_runs = 0)$evidence$log_bayes_factor
  gap <- diagnose_gap(toy$fit, discrepancy = d, max_runs = 0,
                      prior_models = c(none = exp(log_bf - 0.5), other = 1))
  expect_identical(gap$verdict$answer, "other")
  expect_identical(gap$verdict$reason, "blocks")
  expect_identical(gap$settings$where, "check")
  expect_true(any(gap$where$flagged))
  expect_match(capture.output(print(gap))[2], "local gap")
})

test_that("a gap at one setting and one time is located there by $where", {
  toy <- toy_gap(0, bump = 0.3)                     # at the second load around t = 0.5
  gap <- diagnose_gap(toy$fit, windows = 5, discrepancy = small_disc(), seed = 1)
  expect_identical(gap$verdict$answer, "other")
  wh <- gap$where
  expect_true(any(wh$flagged))
  expect_true(all(wh$x[wh$flagged] == 2))
  top <- wh[which.max(wh$score), ]
  expect_identical(top$x, 2L)
  expect_true(top$from <= 0.5 && top$to >= 0.5 || abs(top$from - 0.5) < 0.21)
  # the map is the discrepancy's posterior mean: largest at the bump
  m <- gap$map
  expect_identical(m$x[which.max(abs(m$residual))], 2L)
  expect_lt(abs(m$t[which.max(abs(m$residual))] - 0.5), 0.15)
})

test_that("replicated field data and noise groups are diagnosed, with the exact evidence", {
  toy <- toy_gap(0.3)
  set.seed(3)
  y <- rbind(toy$field$y, toy$field$y + matrix(stats::rnorm(length(toy$field$y), sd = 0.05), 3))
  rep_field <- field_data(y, x = rbind(toy$x, toy$x), t = toy$t)
  d <- small_disc()
  fit <- suppressWarnings(calibrate(toy$lib, rep_field, n_iter = 200, burn_in = 50, seed = 1))
  gap <- diagnose_gap(fit, discrepancy = d, max_runs = 0)
  ev <- discrepancy_evidence(posterior_exact(toy$lib, rep_field, discrepancy = d))
  expect_equal(gap$evidence$log_bayes_factor, ev$log_bayes_factor, tolerance = 1e-10)
  expect_identical(gap$verdict$answer, "other")
  # with replicates the evidence alone answers (no leave-block-out check)
  expect_identical(gap$settings$where, "discrepancy")
  grouped <- suppressWarnings(calibrate(toy$lib, rep_field, n_iter = 200, burn_in = 50, seed = 1,
                                        noise_groups = "x"))
  gap_g <- diagnose_gap(grouped, discrepancy = d, max_runs = 0)
  ev_g <- discrepancy_evidence(posterior_exact(toy$lib, rep_field, discrepancy = d,
                                               noise_groups = "x"))
  expect_equal(gap_g$evidence$log_bayes_factor, ev_g$log_bayes_factor, tolerance = 1e-10)
  expect_identical(gap_g$verdict$answer, "other")
  expect_true(any(gap_g$where$flagged))
})

test_that("missing cells and relative sd: the exact evidence, unobserved blocks not checked", {
  toy <- toy_gap(0.2, missing = gap_missing, rel_sd = gap_rel_sd)
  d <- small_disc()
  gap <- diagnose_gap(toy$fit, discrepancy = d, max_runs = 0)
  ev <- discrepancy_evidence(posterior_exact(toy$lib, toy$field, discrepancy = d))
  expect_equal(gap$evidence$log_bayes_factor, ev$log_bayes_factor, tolerance = 1e-10)
  expect_identical(gap$verdict$answer, "other")
  expect_true(all(is.na(gap$map$residual[gap_missing])))
  expect_false(anyNA(gap$map$residual[-gap_missing]))
})

test_that("a fit made with a discrepancy is diagnosed as the fit without it", {
  toy <- toy_gap(0.2)
  d <- small_disc()
  with_d <- suppressWarnings(calibrate(toy$lib, toy$field, n_iter = 200, burn_in = 50, seed = 1,
                                       discrepancy = d))
  expect_equal(diagnose_gap(with_d, discrepancy = d, max_runs = 0)$which,
               diagnose_gap(toy$fit, discrepancy = d, max_runs = 0)$which, tolerance = 1e-8)
})

test_that("an emulated library is diagnosed without candidates", {
  skip_if_not_installed("RobustGaSP")
  lib <- emulated_toy_library(n_runs = 300)
  field <- emulated_toy_field()
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 200, burn_in = 50, seed = 1))
  # (the emulator's leave-one-out error near the posterior is warned about)
  gap <- suppressWarnings(diagnose_gap(fit, discrepancy = small_disc(), max_runs = 0))
  expect_s3_class(gap, "gap_diagnosis")
  expect_identical(gap$verdict$answer, "none")
})

test_that("print, summary and plot say it is a discrepancy against none", {
  gap <- diagnose_gap(toy_gap(0.3)$fit, discrepancy = small_disc(), max_runs = 0)
  out <- capture.output(print(gap))
  expect_match(out[1], "no candidates")
  expect_true(any(grepl("cannot absorb", out)))
  expect_true(any(grepl("log Bayes factor for a discrepancy", out)))
  s <- capture.output(print(summary(gap)))
  expect_true(any(grepl("without candidates", s)))
  expect_false(any(grepl("Held-out|separable", s)))
  expect_true(any(grepl("discrepancy away from zero", s)))
  expect_true(any(grepl("worst at load=", out)))              # the settings by name
  p <- plot(gap)
  expect_s3_class(p, "ggplot")
  expect_match(p$labels$subtitle, "discrepancy")
  # every flagged block is outlined on its setting's row
  rects <- ggplot2::ggplot_build(p)$data[[2]]
  expect_equal(nrow(rects), sum(gap$where$flagged))
  expect_false(anyNA(rects$ymin))
})

test_that("a discrepancy without the ratio 0 is refused", {
  toy <- toy_gap(0)
  expect_error(diagnose_gap(toy$fit, discrepancy = gp_discrepancy(ratio = c(1, 10))),
               "ratio.*holds 0", class = "griddy_error_input")
  expect_error(diagnose_gap(toy$fit, discrepancy = "gp"), "gp_discrepancy",
               class = "griddy_error_input")
})

test_that("diagnose_gap() on one measurement says it cannot tell, as the screen does", {
  # issue 33: a library of one output (one x, one t) got "no gap (P = 50%)"
  k <- seq(0.5, 1.5, length.out = 11)
  lib <- sim_library(data.frame(k = k), matrix(2 * k, ncol = 1))
  fit <- suppressWarnings(calibrate(lib, field_data(2.04), n_iter = 200, burn_in = 50, seed = 1))
  gap <- diagnose_gap(fit, seed = 1)
  expect_identical(gap$verdict$reason, "unweighable")
  expect_true(is.na(gap$verdict$prob))
  out <- paste(capture.output(print(gap), width = 1000), collapse = " ")
  expect_match(out, "Verdict: cannot tell (no evidence possible", fixed = TRUE)
  expect_false(grepl("no gap (P", out, fixed = TRUE))
  out <- paste(capture.output(print(summary(gap)), width = 1000), collapse = " ")
  expect_match(out, "cannot tell whether there is a gap", fixed = TRUE)
})
