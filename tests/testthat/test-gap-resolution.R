# The toy of helper-gap.R on a coarse library (a by 0.1), with the truth
# between its runs: a = 1.0437.
offgrid_gap <- function(s_true, seed = 1) {
  toy <- toy_gap(s_true, sd = 0.02, seed = seed, a_true = 1.0437,
                 a_grid = seq(0.5, 1.5, by = 0.1))
  list(fit = toy$fit, candidates = list(quadratic = toy$quad, scale = toy$scale))
}

test_that("a truth between runs with no effect is not mistaken for an effect", {
  for (seed in 1:2) {
    g <- offgrid_gap(0, seed = seed)
    # compared as they are, the coarse library's misfit reads as a gap
    as_is <- diagnose_gap(g$fit, g$candidates, max_runs = 0)
    expect_false(as_is$verdict$answer == "none")
    matched <- diagnose_gap(g$fit, g$candidates, seed = 1)
    expect_identical(matched$verdict$answer, "none")
  }
})

test_that("an effect between runs, and between strengths, is still named", {
  for (s in c(0.2, 0.15)) {
    g <- offgrid_gap(s)
    matched <- diagnose_gap(g$fit, g$candidates, seed = 1)
    expect_identical(matched$verdict$answer, "quadratic")
  }
})

test_that("a resolved base is left as it is, and the candidate still nests it", {
  toy <- toy_gap(0.2)
  base <- matched_base(toy$fit, 2000)
  resolved <- !any(resolution_limited(toy$fit)$limited)
  if (resolved) expect_identical(base, toy$fit)
  cand <- matched_candidate(toy$quad, base, 2000)
  zero <- cand$theta$s == 0
  # the zero level is the base's runs, first (Y holds the rows after them)
  expect_identical(which(zero), seq_len(cand$base_rows))
  expect_identical(nrow(cand$Y), sum(!zero))
  expect_equal(cand$C[zero, , drop = FALSE], unname(base$C))
  expect_equal(as.matrix(cand$theta[zero, names(lib_theta(base$library))]),
               as.matrix(lib_theta(base$library)), ignore_attr = TRUE)
  expect_equal(sum(exp(cand$log_prior)), 1)
  expect_equal(sum(exp(cand$log_prior[zero])), 1 / 4)
})

test_that("the confounding screen works on the fit's own library, not the refined one", {
  toy <- toy_gap(0.2)
  seen <- new.env()
  trace("confounding_screen", where = asNamespace("griddy"), print = FALSE,
        tracer = bquote(assign("runs", nrow(ctx$theta), envir = .(seen))))
  on.exit(untrace("confounding_screen", where = asNamespace("griddy")), add = TRUE)
  diagnose_gap(toy$fit, list(quadratic = toy$quad), seed = 1)
  expect_identical(seen$runs, lib_n_runs(toy$fit$library))
})


test_that("a model that more runs cannot resolve stops refining after one round", {
  # "scale" is imitated by a shift of a: its strength stays flat over the
  # non-zero levels, so on a dense library its marginal never gets enough
  # effective values from predicted runs
  toy <- toy_gap(0.2, a_grid = seq(0.5, 1.5, length.out = 1001))
  strength <- lib_theta(toy$scale)$s
  rows <- which(strength > 0)
  part <- sim_library(lib_theta(toy$scale)[rows, ], lib_outputs(toy$scale, rows),
                      x = toy$x, t = toy$t)
  problem <- new_griddy_problem(part, toy$fit$y_field, toy$fit$prior, lib_log_prior(part),
                                toy$fit$setup)
  go <- function(settled) {
    withr::with_seed(1, refine_rounds(problem, NULL, 1000, 200, settled = settled))
  }
  plain <- go(NULL)
  early <- go(settled_in_range)
  expect_identical(plain$reason, "max_runs")
  expect_identical(early$reason, "settled")
  expect_equal(early$runs_added, 200)
  # the rounds it ran are the same rounds
  expect_identical(early$history, plain$history[seq_along(early$history)])
  # what settled: an interval spanning the whole range, not moving
  last <- early$history[[length(early$history)]]
  expect_true(any(last$limited))
})
