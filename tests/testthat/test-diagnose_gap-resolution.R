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
  expect_equal(cand$Y[zero, ], lib_outputs(base$library))
  expect_equal(sum(exp(cand$log_prior)), 1)
  expect_equal(sum(exp(cand$log_prior[zero])), 1 / 4)
})

test_that("a predicted run's leave-block pieces are those of its dense covariance", {
  toy <- refine_toy()
  refined <- refine(toy$fit, max_runs = 200, runs_per_round = 100, seed = 2)
  lib <- refined$library
  ctx <- gap_context(refined)
  point <- ctx$points[[1]]
  em <- run_errors(lib)
  j <- lib_n_runs(lib$base) + 5L
  err <- run_emulation(em, j, ctx$obs)
  r <- refined$y_field - lib_outputs(lib, j)[1, ]
  wood <- emulated_inverse(ctx, point, r, err)
  S <- diag(length(r)) + tcrossprod(err$V)
  Si <- solve(S)
  expect_equal(wood$Q, drop(t(r) %*% Si %*% r), tolerance = 1e-10)
  expect_equal(wood$logdet, as.numeric(determinant(S)$modulus), tolerance = 1e-10)
  W <- 11:20
  bs <- emulated_block(wood, block_precision(ctx, point, W, W, 1L), W)
  h <- Si %*% r
  expect_equal(bs$D, drop(t(h[W]) %*% solve(Si[W, W], h[W])), tolerance = 1e-10)
  expect_equal(bs$logdet_BB, as.numeric(determinant(Si[W, W])$modulus), tolerance = 1e-10)
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

test_that("with missing cells and sd, a predicted run's pieces are those of its dense covariance", {
  toy <- refine_toy()
  y <- toy$field$y
  y[c(5:9, 30)] <- NA
  rs <- 1 + 0.3 * sin(1:40)
  field <- field_data(y, t = toy$lib$t, sd = rs)
  fit <- suppressWarnings(calibrate(toy$lib, field, n_iter = 300, burn_in = 100, seed = 1))
  refined <- refine(fit, max_runs = 200, runs_per_round = 100, seed = 2)
  lib <- refined$library
  ctx <- gap_context(refined)
  obs <- ctx$obs
  point <- ctx$points[[1]]
  j <- lib_n_runs(lib$base) + 5L
  err <- run_emulation(run_errors(lib), j, obs)
  r <- (refined$y_field - lib_outputs(lib, j)[1, ])[obs]
  wood <- emulated_inverse(ctx, point, r, err)
  S <- diag(rs[obs]^2) + tcrossprod(err$V)
  Si <- solve(S)
  expect_equal(wood$Q, drop(t(r) %*% Si %*% r), tolerance = 1e-10)
  expect_equal(wood$logdet, as.numeric(determinant(S)$modulus) - 2 * sum(log(rs[obs])),
               tolerance = 1e-10)
  # the same likelihood as the refined fit's own table
  C <- structure(matrix(wood$Q), extra_logdet = matrix(wood$logdet))
  expect_equal(drop(fold_extra_logdet(C, refined$prior, ctx$n)), refined$C[j, 1], tolerance = 1e-8)
  B <- 11:20
  bs <- emulated_block(wood, block_precision(ctx, point, B, B, 1L), B)
  h <- Si %*% r
  expect_equal(bs$D, drop(t(h[B]) %*% solve(Si[B, B], h[B])), tolerance = 1e-10)
  expect_equal(bs$logdet_BB, as.numeric(determinant(Si[B, B])$modulus), tolerance = 1e-10)
})
