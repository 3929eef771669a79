test_that("print reads as a verdict with the numbers", {
  toy <- toy_gap(0.2)
  gap <- diagnose_gap(toy$fit, list(scale = toy$scale, quadratic = toy$quad))
  out <- paste(capture.output(print(gap)), collapse = " ")
  expect_match(out, "best explained by 'quadratic'")
  expect_match(out, "held-out settings from")
  expect_match(out, "'scale' is confounded with a: ")
  null <- diagnose_gap(toy_gap(0)$fit, list(quadratic = toy$quad))
  expect_match(paste(capture.output(print(null)), collapse = " "), "No detectable gap")
  other <- diagnose_gap(toy_gap(0.3)$fit, list(scale = toy$scale))
  expect_match(paste(capture.output(print(other)), collapse = " "), "no candidate explains")
})

test_that("plot draws a map of the gap with flagged blocks outlined", {
  toy <- toy_gap(0, bump = 0.3)
  gap <- diagnose_gap(toy$fit, list(quadratic = toy$quad), windows = 6)
  p <- plot(gap)
  expect_s3_class(p, "ggplot")
  expect_true(any(vapply(p$layers, function(l) inherits(l$geom, "GeomRect"), logical(1))))
  expect_silent(ggplot2::ggplot_build(p))
  # one output per setting: bars
  lib1 <- sim_library(data.frame(a = 1:5), matrix(rnorm(20), 5, 4), x = data.frame(u = 1:4))
  cand <- sim_library(expand.grid(a = 1:5, s = 0:1),
                      rbind(lib1$y, lib1$y + 1), x = data.frame(u = 1:4))
  fit <- suppressWarnings(calibrate(lib1, field_data(lib1$y[3, ] + 0.1, x = data.frame(u = 1:4)),
                                    n_iter = 200, burn_in = 50, seed = 1,
                                    prior = list(shape = 1, rate = 0.01)))
  g1 <- diagnose_gap(fit, list(shift = cand))
  expect_equal(nrow(g1$where), 4)
  expect_s3_class(plot(g1), "ggplot")
})

test_that("a gap the base model's block check flags is 'other' even when evidence says none", {
  toy <- toy_gap(0, bump = 0.3)
  gap <- diagnose_gap(toy$fit, list(quadratic = toy$quad), windows = 6)
  expect_true(any(gap$where$flagged))
  top <- gap$which$effect[!gap$which$confounded][1]
  if (top == "none") {
    expect_identical(gap$verdict$answer, "other")
    expect_identical(gap$verdict$reason, "blocks")
    expect_match(paste(capture.output(print(gap)), collapse = " "), "local or rough")
  } else {
    expect_identical(gap$verdict$reason, "evidence")
  }
  expect_false(gap$verdict$answer %in% c("none", "quadratic"))
})

test_that("the verdict label names a gap the blocks flag without a tiny probability", {
  # the plot's title read "answer: other (P = 1.1e-08)"
  expect_identical(verdict_label(list(answer = "other", reason = "blocks", prob = 1.1e-8)),
                   "a local gap no candidate explains")
  expect_identical(verdict_label(list(answer = "quadratic", reason = "evidence", prob = 0.976)),
                   "best explained by 'quadratic' (P = 97.6%)")
  expect_identical(verdict_label(list(answer = "none", reason = "evidence", prob = 2e-4)),
                   "no gap (P = < 0.1%)")
})
