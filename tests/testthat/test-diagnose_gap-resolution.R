# The toy of helper-gap.R on a coarse library (a by 0.1), with the truth
# between its runs: a = 1.0437.
offgrid_gap <- function(s_true, a_true = 1.0437, sd = 0.02, seed = 1, n_t = 30) {
  t <- seq(0, 1, length.out = n_t)
  x <- data.frame(load = c(1, 2, 3))
  sim <- function(a, s) unlist(lapply(x$load, function(l) a * l * sin(3 * t) + s * l^2 * t^2))
  base <- data.frame(a = seq(0.5, 1.5, by = 0.1))
  lib <- sim_library(base, t(vapply(base$a, sim, numeric(3 * n_t), s = 0)), x = x, t = t)
  g1 <- expand.grid(a = base$a, s = c(0, 0.1, 0.2, 0.3))
  quad <- sim_library(g1, t(mapply(sim, g1$a, g1$s)), x = x, t = t)
  g2 <- expand.grid(a = base$a, s = c(0, 0.1, 0.2))
  scale <- sim_library(g2, t(mapply(function(a, s) sim(a * (1 + s), 0), g2$a, g2$s)),
                       x = x, t = t)
  set.seed(seed)
  y <- sim(a_true, s_true) + stats::rnorm(3 * n_t, sd = sd)
  field <- field_data(matrix(y, 3, byrow = TRUE), x = x, t = t)
  fit <- suppressWarnings(calibrate(lib, field, n_iter = 300, burn_in = 100, seed = 1))
  list(fit = fit, candidates = list(quadratic = quad, scale = scale))
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
  expect_equal(cand$Y[zero, ], lib_outputs(base$library))
  expect_equal(sum(exp(cand$log_prior)), 1)
  expect_equal(sum(exp(cand$log_prior[zero])), 1 / 4)
})

test_that("a predicted run's leave-block pieces are those of its dense covariance", {
  toy <- refine_toy()
  refined <- refine(toy$fit, max_runs = 200, runs_per_round = 100, seed = 2)
  lib <- refined$library
  ctx <- gap_context(refined)
  node <- ctx$nodes[[1]]
  em <- run_errors(lib)
  j <- lib_n_runs(lib$base) + 5L
  err <- run_emulation(em, j)
  r <- refined$y_field - lib_outputs(lib, j)[1, ]
  wood <- emulated_inverse(node, matrix(r, ctx$n_t, ctx$n_x), err, ctx$n_t, ctx$n_x)
  S <- diag(length(r)) + tcrossprod(err$V)
  Si <- solve(S)
  expect_equal(wood$Q, drop(t(r) %*% Si %*% r), tolerance = 1e-10)
  expect_equal(wood$logdet, as.numeric(determinant(S)$modulus), tolerance = 1e-10)
  W <- 11:20
  bs <- emulated_block(wood, node, W, 1L, ctx$n_t)
  h <- Si %*% r
  expect_equal(bs$D, drop(t(h[W]) %*% solve(Si[W, W], h[W])), tolerance = 1e-10)
  expect_equal(bs$logdet_BB, as.numeric(determinant(Si[W, W])$modulus), tolerance = 1e-10)
})
