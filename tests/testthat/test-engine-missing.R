# Missing cells on the full field's kernel (R/engine-missing.R,
# masked_quad_forms_cpp()): C and log|R_g| against the dense algebra of the
# observed cells, and the exact posterior against the dense path.

missing_case <- function(n_x = 4, n_t = 9, N = 60, seed = 1) {
  set.seed(seed)
  t <- sort(c(0, 1, runif(n_t - 2)))
  x <- data.frame(x = seq(0, 1, length.out = n_x))
  Y <- matrix(rnorm(N * n_x * n_t), N)
  list(lib = sim_library(data.frame(a = runif(N)), Y, x = x, t = t), Y = Y, x = x, t = t,
       y = matrix(rnorm(n_x * n_t), n_x, n_t))
}

# C and log|S R_g S| over the observed cells by dense algebra, per grid point
dense_reference <- function(case, field, setup) {
  layout <- field_layout(case$lib, field)
  obs <- which(!is.na(layout$y))
  sd <- if (is.null(layout$sd_mean)) rep(1, length(obs)) else layout$sd_mean[obs]
  pure <- sum(layout$pure_ss[obs])
  vapply(seq_along(setup$gx), function(g) {
    R_x <- crossprod(matrix(setup$Rx_chol[, , setup$gx[g]], nrow(case$x)))
    R <- kronecker(R_x, corr_t(case$t, setup$rho_t[setup$gt[g]]))[obs, obs] * outer(sd, sd)
    resid <- t(layout$y[obs] - t(case$Y[, obs]))
    c(rowSums((resid %*% solve(R)) * resid) + pure,
      as.numeric(determinant(R)$modulus) + layout$log_sd_excess)
  }, numeric(nrow(case$Y) + 1L))
}

masked_setup <- function(case, field, rho_x, rho_t) {
  layout <- field_layout(case$lib, field)
  correlation_setup(case$lib, rho_x, rho_t, 2, noise_pattern(case$lib, layout, NULL, thesis_prior()))
}

expect_matches_dense <- function(case, field, rho_x, rho_t) {
  setup <- masked_setup(case, field, rho_x, rho_t)
  expect_false(is.null(setup$masked))
  ref <- dense_reference(case, field, setup)
  N <- nrow(case$Y)
  C <- plain_quad_forms(case$Y, field_layout(case$lib, field)$y, setup)
  expect_lt(max(abs(C / ref[seq_len(N), ] - 1)), 1e-10)
  expect_lt(max(abs(masked_logdet(setup$masked) - ref[N + 1L, ])), 1e-9)
  expect_lt(max(abs(setup$logdet - ref[N + 1L, ])), 1e-9)
}

rho_cases <- list(list(0, 0), list(c(0, 0.6, 0.9), 0), list(0, c(0.4, 0.9)),
                  list(c(0, 0.5, 0.9), c(0, 0.5, 0.9)))

test_that("missing cells at random, in a run and across a whole t or setting match the dense algebra", {
  case <- missing_case()
  y <- case$y
  y[c(2, 7, 11, 20, 31, 33)] <- NA  # scattered
  y[2, 4:7] <- NA                    # a setting partly missing
  y[, 9] <- NA                       # the last t at every setting
  y[4, ] <- NA                       # a whole setting
  field <- field_data(y, x = case$x, t = case$t)
  for (rho in rho_cases) expect_matches_dense(case, field, rho[[1]], rho[[2]])
})

test_that("the first t missing, adjacent missing t and a missing cell between two runs of them match", {
  case <- missing_case(n_x = 3, n_t = 8, seed = 2)
  y <- case$y
  y[, 1] <- c(NA, 1, NA)
  y[1, 2:3] <- NA
  y[2, 3:4] <- NA
  y[3, 4:5] <- NA
  field <- field_data(y, x = case$x, t = case$t)
  for (rho in rho_cases) expect_matches_dense(case, field, rho[[1]], rho[[2]])
})

test_that("replicates (unequal counts) with missing cells match the dense algebra, pure error included", {
  case <- missing_case(n_x = 3, n_t = 7, seed = 3)
  long <- data.frame(x = rep(case$x$x, each = 7), t = rep(case$t, 3))
  set.seed(4)
  long <- long[sort(sample(nrow(long), 15)), ]
  long <- long[rep(seq_len(nrow(long)), sample(1:3, nrow(long), replace = TRUE)), ]
  long$y <- rnorm(nrow(long))
  field <- field_data(long)
  expect_true(any(field_layout(case$lib, field)$pure_ss > 0))
  for (rho in rho_cases) expect_matches_dense(case, field, rho[[1]], rho[[2]])
})

test_that("posterior_exact() with missing cells is the dense path's to 1e-10", {
  case <- missing_case(N = 200, seed = 5)
  y <- case$y
  y[sample(length(y), 8)] <- NA
  field <- field_data(y, x = case$x, t = case$t)
  fast <- posterior_exact(case$lib, field, rho_x = c(0, 0.5), rho_t = c(0, 0.7))
  problem <- calibration_problem(case$lib, field, c(0, 0.5), c(0, 0.7), NULL, 2, NULL)
  dense <- problem$setup
  dense$masked <- NULL  # the dense factors' products, as before
  old <- exact_from_problem(new_griddy_problem(case$lib, problem$y_field, problem$prior,
                                               problem$log_prior_run, dense))
  expect_lt(abs(attr(fast, "log_mass") / attr(old, "log_mass") - 1), 1e-10)
  expect_lt(max(abs(fast$run - old$run)), 1e-10)
  expect_lt(max(abs(fast$grid$prob - old$grid$prob)), 1e-10)
})

test_that("missing-cell forms do not depend on the number of threads", {
  skip_if(griddy_threads() < 2L && parallel::detectCores() < 2L)
  case <- missing_case(N = 700, seed = 6)
  y <- case$y
  y[sample(length(y), 7)] <- NA
  field <- field_data(y, x = case$x, t = case$t)
  setup <- masked_setup(case, field, c(0, 0.5), c(0, 0.8))
  y_lib <- field_layout(case$lib, field)$y
  expect_identical(plain_quad_forms(case$Y, y_lib, setup, threads = 1L),
                   plain_quad_forms(case$Y, y_lib, setup, threads = 2L))
})

test_that("a non-finite output at an observed cell is an error, at a missing cell none", {
  case <- missing_case(n_x = 2, n_t = 5, N = 20, seed = 7)
  y <- case$y
  y[1, 2] <- NA
  field <- field_data(y, x = case$x, t = case$t)
  setup <- masked_setup(case, field, c(0, 0.5), 0.5)
  y_lib <- field_layout(case$lib, field)$y
  Y <- case$Y
  Y[3, 2] <- NA  # the missing cell (setting 1, t 2): never read
  expect_true(all(is.finite(plain_quad_forms(Y, y_lib, setup))))
  Y[3, 1] <- Inf
  expect_error(plain_quad_forms(Y, y_lib, setup), "not finite")
})

test_that("noise groups keep the dense path", {
  case <- missing_case(n_x = 2, n_t = 5, N = 20, seed = 8)
  y <- case$y
  y[1, 2] <- NA
  field <- field_data(y, x = case$x, t = case$t)
  layout <- field_layout(case$lib, field)
  setup <- correlation_setup(case$lib, 0, 0.5, 2,
                             noise_pattern(case$lib, layout, "x", thesis_prior()))
  expect_null(setup$masked)
})

test_that("one coordinate or one setting observed (a reduced grid of one t or one x) matches", {
  case <- missing_case(n_x = 3, n_t = 6, seed = 9)
  one_t <- case$y
  one_t[, -3] <- NA
  one_x <- case$y
  one_x[-2, ] <- NA
  one_x[2, c(1, 4)] <- NA
  for (y in list(one_t, one_x)) {
    field <- field_data(y, x = case$x, t = case$t)
    for (rho in rho_cases) expect_matches_dense(case, field, rho[[1]], rho[[2]])
  }
})
