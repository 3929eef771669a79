# A candidate whose effect is a shift of `a` plus a t^2 term that grows with
# load by h(load): a shift of `a` imitates it where h is 0 and less so where
# h is large. Small enough (eps) to be confounded with `a`.
departing_candidate <- function(toy, h, eps = 0.02) {
  g <- expand.grid(a = lib_theta(toy$lib)$a, s = c(0, 0.1, 0.2))
  extra <- function(s) s * eps * unlist(lapply(toy$x$load, function(l) l * h(l) * toy$t^2))
  y <- t(mapply(function(a, s) toy$sim(a + s, 0) + extra(s), g$a, g$s))
  sim_library(g, y, x = toy$x, t = toy$t)
}

advice_of <- function(gap) gsub("\\s+", " ", paste(gap$verdict$advice, collapse = " "))

test_that("the advice names the high x where the effect departs from the parameter's there", {
  toy <- toy_gap(0)
  gap <- diagnose_gap(toy$fit, list(high = departing_candidate(toy, function(l) (l - 1)^2)))
  expect_true(gap$which$confounded[gap$which$effect == "high"])
  sep <- gap$separation
  expect_identical(sep$load, c(1, 2, 3))
  expect_identical(which.max(sep$unexplained), 3L)
  expect_true(all(diff(sep$ratio) > 0))
  advice <- advice_of(gap)
  expect_match(advice, paste0("'high' imitates a shift of a most closely at load=[12] \\([0-9.]+% ",
                              "of its effect unexplained\\) and least at load=3 \\([0-9.]+%\\): ",
                              "measure at load=3 or above to separate them."))
  # the computed sentence replaces the generic one
  expect_no_match(advice, "To tell a confounded candidate")
  expect_match(gsub("\\s+", " ", paste(capture.output(print(gap)), collapse = " ")),
               "least at load=3")
})

test_that("the advice names the low x when the effect departs there (the mirror case)", {
  toy <- toy_gap(0)
  gap <- diagnose_gap(toy$fit, list(low = departing_candidate(toy, function(l) (3 - l)^2)))
  expect_true(gap$which$confounded[gap$which$effect == "low"])
  expect_identical(which.max(gap$separation$unexplained), 1L)
  expect_match(advice_of(gap), paste0("'low' imitates a shift of a most closely at load=[23] .*",
                                      "least at load=1 .*: measure at load=1 or below"))
})

test_that("an effect a shift imitates alike at every setting, or one setting, gets the generic advice", {
  toy <- toy_gap(0)
  gap <- diagnose_gap(toy$fit, list(scale = toy$scale))
  expect_true(all(gap$separation$unexplained < 1e-6))
  expect_match(advice_of(gap), paste0("'scale' is confounded with a: .* To tell a confounded ",
                                      "candidate from a shift of theta, measure outside the ",
                                      "load range measured \\(1-3\\)"))
  # one x setting: nothing to compare across x
  t <- seq(0, 1, length.out = 30)
  x <- data.frame(load = 2)
  sim <- function(a) a * 2 * sin(3 * t)
  base <- data.frame(a = seq(0.5, 1.5, length.out = 41))
  lib <- sim_library(base, t(vapply(base$a, sim, numeric(30))), x = x, t = t)
  g <- expand.grid(a = base$a, s = c(0, 0.1, 0.2))
  shifted <- sim_library(g, t(mapply(function(a, s) sim(a + s), g$a, g$s)), x = x, t = t)
  set.seed(1)
  field <- field_data(matrix(sim(1) + rnorm(30, sd = 0.05), 1), x = x, t = t)
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 300, burn_in = 100, seed = 1))
  one <- diagnose_gap(fit, list(shifted = shifted))
  expect_true(one$which$confounded[one$which$effect == "shifted"])
  expect_null(one$separation)
  expect_match(advice_of(one), paste0("'shifted' is confounded with a: .* measure at a second ",
                                      "value of load \\(this library has one setting, load=2\\)"))
})

test_that("the separation table: the unexplained share per setting and the ratio's drift", {
  # outputs over 2 settings x 3 t, p at every one: shifting p from 0.5 (the
  # candidate's zero-strength run) to 1 (base run 9) adds 0.5 everywhere; the
  # candidate's effect is twice that at setting 1 and has an orthogonal part
  # at setting 2
  ctx <- list(n_x = 2L, n_t = 3L, x = data.frame(u = c(10, 20)), sd = NULL)
  base_Y <- outer(seq(0, 1, length.out = 9), rep(1, 6))
  cand <- sim_library(data.frame(p = c(0.4, 0.5, 0.5), s = c(0, 0, 1)),
                      rbind(rep(0.4, 6), rep(0.5, 6), rep(0.5, 6) + c(1, 1, 1, 1, 2, 0)),
                      x = ctx$x, t = 1:3)
  sep <- effect_separation(ctx, base_Y, cand, c(3L, 2L), list(j = 9L, nb = 7:8), "p", "bump")
  expect_identical(names(sep), c("effect", "absorbed_by", "setting", "u", "effect_size",
                                 "unexplained", "ratio"))
  expect_equal(sep$effect_size, c(sqrt(3), sqrt(5)))
  # beta = 2: nothing unexplained at setting 1, the orthogonal (0, 1, -1) at setting 2
  expect_equal(sep$unexplained, c(0, sqrt(2 / 5)))
  expect_equal(sep$ratio, c(1, 1))
  s <- design_sentence(sep, ctx$x)
  expect_match(s, "'bump' imitates a shift of p most closely at u=10 \\(0.0% .* least at u=20 \\(63.2%\\)")
  # the ratio does not drift, so no "or above": measure near the setting
  expect_match(s, "measure near u=20 to separate them")
  expect_null(design_sentence(sep[1, ], ctx$x))
  imitator <- list(j = 9L, nb = 7:8)
  expect_null(effect_separation(modifyList(ctx, list(n_x = 1L)), base_Y, cand, c(3L, 2L),
                                imitator, "p", "bump"))
  # no shift at all (the imitator is the zero-strength run's theta): no table
  expect_null(effect_separation(ctx, base_Y, cand, c(3L, 2L), list(j = 5L, nb = 3:4), "p",
                                "bump"))
})
