test_that("an effect a shift of theta imitates is reported as confounded, not attributed", {
  toy <- toy_gap(0)
  # data from the scale effect at strength 0.2: exactly a = 1.2 in the base model
  gap <- diagnose_gap(toy$fit, list(scale = toy$scale, quadratic = toy$quad))
  row <- gap$which[gap$which$effect == "scale", ]
  expect_true(row$confounded)
  expect_lt(row$separable, 0.01)
  expect_identical(row$absorbed_by, "a")
  expect_false(gap$which$confounded[gap$which$effect == "quadratic"])
  # the advice comes from the settings measured, not a system's wording
  # (it suggested "another speed or pressure" for any system)
  advice <- paste(gap$verdict$advice, collapse = " ")
  expect_match(advice, "'scale' is confounded with a: .*outside the load range measured \\(1-3\\)")
  expect_no_match(advice, "speed or pressure")
  expect_false(gap$verdict$answer == "scale")
})

test_that("the nearest row is the exact distances' choice, ties within rounding included", {
  set.seed(2)
  W <- matrix(rnorm(400 * 6), 400) * 1e3
  w <- W[17, ] + 1e-9                                 # almost a library row
  W[18, ] <- W[17, ] - 2e-9                           # a closer one within rounding
  exact <- function(drop = 0L) {
    d <- colSums((t(W) - w)^2)
    d[drop] <- Inf
    which.min(d)
  }
  expect_identical(nearest_row(W, w, rowSums(W^2)), exact())
  expect_identical(nearest_row(W, w, rowSums(W^2), drop = 17L), exact(17L))
  v <- rnorm(6)
  expect_identical(nearest_row(W, v, rowSums(W^2)), which.min(colSums((t(W) - v)^2)))
})

test_that("the screen's whitened base runs, read a few at a time, are the whitened library", {
  toy <- toy_gap(0.2, rho_t = c(0, 0.3), missing = gap_missing, rel_sd = gap_rel_sd)
  for (fit in list(toy_gap(0.2, rho_t = c(0, 0.3))$fit, toy$fit)) {
    ctx <- gap_context(fit)
    terms <- list(Y = lib_outputs(fit$library), Q = fit$C,
                  lj = collapsed_log_joint(fit$C, ctx$n, ctx$logdet, ctx$prior,
                                           fit$log_prior_run, ctx$log_prior_grid))
    white <- screen_white(ctx, terms)
    W <- whiten_rows(terms$Y, white$point, ctx$n_x, ctx$n_t)
    expect_equal(white$rows(c(3, 7)), W[c(3, 7), ], tolerance = 1e-12)
    expect_equal(white$norm2, rowSums(W^2), tolerance = 1e-10)
    w <- W[5, ] + 0.01
    expect_equal(white$dot(w), drop(W %*% w), tolerance = 1e-12)
    expect_identical(nearest_row(NULL, w, white$norm2, rows = white$rows, dot = white$dot),
                     nearest_row(W, w, rowSums(W^2)))
  }
})
