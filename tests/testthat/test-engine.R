test_that("whitening and colouring are inverse and give the quadratic forms", {
  toy <- toy_xt(n_per_dim = 3, n_t = 6)
  lib <- toy$library
  y <- field_vector(lib, toy$field)
  setup <- correlation_setup(lib, rho_x = list(load = 0.6, speed = 0.3), rho_t = c(0, 0.5))
  C <- misfit_table(lib, y, setup, thesis_prior())$C
  E <- -sweep(lib$y, 2, y, "-")
  for (g in seq_len(n_grid_points(setup))) {
    point <- grid_point(setup, g)
    W <- whiten_rows(E, point, 3L, 6L)
    expect_equal(rowSums(W^2), C[, g], tolerance = 1e-10)
    expect_equal(colour_rows(W, point, 3L, 6L), E, tolerance = 1e-10)
  }
})

test_that("the collapsed log joint sums to the log evidence and matches the dense formula", {
  toy <- toy_ar1(n_runs = 30, n_t = 15)
  problem <- local_problem(toy$library, toy$field, rho_t = c(0, 0.4))
  lj <- collapsed_log_joint(problem$C, problem$n_obs, problem$setup$logdet, problem$prior,
                            problem$log_prior_run, problem$log_prior_grid)
  expect_equal(log_sum_exp(lj), posterior_exact(toy$library, toy$field,
                                                rho_t = c(0, 0.4))$log_evidence)
  y <- field_vector(toy$library, toy$field)
  R <- corr_t(toy$library$t, 0.4)
  r <- y - toy$library$y[7, ]
  a <- 1e-9
  b <- 1e-9
  n <- 15
  dense <- a * log(b) - lgamma(a) + lgamma(a + n / 2) - n / 2 * log(2 * pi) -
    determinant(R)$modulus[1] / 2 - (a + n / 2) * log(b + drop(r %*% solve(R, r)) / 2) -
    log(30) - log(2)
  expect_equal(lj[7, 2], dense, tolerance = 1e-10)
})

test_that("a rho_t whose neighbour correlation rounds to 1 is refused", {
  toy <- toy_ar1(n_runs = 20, n_t = 10)
  expect_error(calibrate(toy$library, toy$field, rho_t = c(0, 1 - 2^-53), n_iter = 10,
                         burn_in = 0),
               class = "griddy_error_input", regexp = "rounds to 1")
  expect_error(posterior_exact(toy$library, toy$field, rho_t = 1 - 2^-53),
               class = "griddy_error_input")
})

test_that("a misfit that overflows is an error naming the output scale, never NaN weights", {
  toy <- toy_ar1(n_runs = 20, n_t = 10)
  big <- sim_library(toy$library$theta, toy$library$y * 1e154, t = toy$library$t)
  field <- field_data(toy$field$y * 1e154)
  expect_error(calibrate(big, field, n_iter = 100, burn_in = 10, seed = 1),
               class = "griddy_error_numeric", regexp = "overflow")
  expect_error(posterior_exact(big, field), class = "griddy_error_numeric")
})

test_that("the C++ entry points refuse shapes that do not fit", {
  Y <- matrix(1, 4, 6)
  cube <- array(diag(2), c(2, 2, 1))
  expect_error(quad_forms_cpp(Y, rep(1, 5), cube, matrix(0, 2, 1)), "do not split")
  expect_error(quad_forms_cpp(Y, rep(1, 8), cube, matrix(0, 3, 1)), "columns")
  expect_error(quad_forms_cpp(Y, rep(1, 6), cube, matrix(0, 3, 1)), "lag coefficients")
  Y[2, 3] <- NA
  expect_error(quad_forms_cpp(Y, rep(1, 6), cube, matrix(0, 2, 1)), "not finite")
  C <- matrix(c(1, NaN), 2, 1)
  expect_error(collapsed_heads_cpp(C, c(0, 0), 1, 1, 0), "NA, NaN or Inf")
  expect_error(collapsed_heads_cpp(matrix(1, 3, 1), c(0, 0), 1, 1, 0), "run priors")
  options <- list(update = "thesis", n_obs = 2, shape = 1, rate = 1, tol = 0, n_iter = 5,
                  first_iter = 1L, burn_in = 0L, thin = 1L, logdet = 0, log_prior_run = c(0, 0),
                  log_prior_grid = 0)
  # a draw never returns a run of zero weight: all-NaN weights are an error
  C <- matrix(NaN, 2, 1)
  expect_error(run_order_cpp(C), "NA, NaN or Inf")
  expect_error(gibbs_chain_cpp(C, list(order = matrix(0:1, 2, 1)), options, 0L, 1),
               "weights sum to")
  options$log_prior_run <- 0
  expect_error(gibbs_chain_cpp(matrix(1, 2, 1), list(order = matrix(0L, 2, 1)), options, 0L, 1),
               "run priors")
  options$log_prior_run <- c(0, 0)
  expect_error(gibbs_chain_cpp(matrix(1, 2, 1), list(order = matrix(0L, 2, 1)), options, 3L, 1),
               "starting grid point")
})

test_that("with missing field data the posterior is that of the observed points (dense algebra)", {
  prior <- list(shape = 2, rate = 0.5)
  for (missing in list(c(2, 7, 8, 13), 6:10, sample(15, 5))) {
    toy <- toy_missing(missing)
    ex <- posterior_exact(toy$library, toy$field, rho_x = c(0, 0.4), rho_t = c(0.2, 0.7),
                          prior = prior)
    lj <- brute_log_joint(toy, rho_grid(toy$library, c(0, 0.4), c(0.2, 0.7)), prior)
    expect_equal(ex$joint, exp(lj - log_sum_exp(lj)), tolerance = 1e-10)
    expect_equal(ex$log_evidence, log_sum_exp(lj), tolerance = 1e-10)
  }
  # the C of plain_quad_forms() are the dense quadratic forms
  toy <- toy_missing()
  pr <- local_problem(toy$library, toy$field, rho_x = 0.4, rho_t = 0.7, prior = prior)
  obs <- which(!is.na(toy$y))
  R <- kronecker(corr_x(toy$x, 0.4), corr_t(toy$t, 0.7))[obs, obs]
  r <- toy$y[obs] - toy$Y[3, obs]
  expect_equal(pr$C[3, 1], drop(t(r) %*% solve(R, r)))
  expect_identical(pr$n_obs, 11L)
})

test_that("complete data keep the Kronecker path and its results", {
  toy <- toy_missing(missing = integer(0))
  pr <- local_problem(toy$library, toy$field, rho_x = c(0, 0.4), rho_t = c(0.2, 0.7))
  expect_null(pr$setup$dense)
  expect_identical(pr$C, quad_forms_cpp(toy$Y, toy$y, pr$setup$Rx_inv, pr$setup$phi))
})

test_that("noise groups: the folded C gives the sum over groups of the Gamma-normal likelihoods", {
  prior <- list(shape = 2, rate = 0.5)
  toy <- toy_missing()
  grid <- rho_grid(toy$library, c(0, 0.4), c(0.2, 0.7))
  by_t <- c("a", "a", "b", "b", "b")
  ex <- posterior_exact(toy$library, toy$field, rho_x = c(0, 0.4), rho_t = c(0.2, 0.7),
                        prior = prior, noise_groups = by_t)
  lj <- brute_log_joint(toy, grid, prior, groups = rep(by_t, 3))
  expect_equal(ex$joint, exp(lj - log_sum_exp(lj)), tolerance = 1e-10)
  expect_equal(ex$log_evidence, log_sum_exp(lj), tolerance = 1e-10)
  # one group per x setting, and labels per library output
  ex_x <- posterior_exact(toy$library, toy$field, rho_t = c(0.2, 0.7), prior = prior,
                          noise_groups = "x")
  lj_x <- brute_log_joint(toy, rho_grid(toy$library, 0, c(0.2, 0.7)), prior,
                          groups = rep(1:3, each = 5))
  expect_equal(ex_x$log_evidence, log_sum_exp(lj_x), tolerance = 1e-10)
  ex_l <- posterior_exact(toy$library, toy$field, rho_t = c(0.2, 0.7), prior = prior,
                          noise_groups = rep(c("p", "q", "r"), each = 5))
  expect_equal(ex_l$joint, ex_x$joint)
  expect_error(posterior_exact(toy$library, toy$field, noise_groups = 1:4),
               "one per output coordinate \\(5\\) or one per library output \\(15\\)",
               class = "griddy_error_input")
  lonely <- rep("a", 15)
  lonely[c(2, 7)] <- "b"
  expect_error(posterior_exact(toy$library, toy$field, noise_groups = lonely),
               "Noise group\\(s\\) b hold no field measurement", class = "griddy_error_input")
})

test_that("relative sd equals dividing the field data and the outputs by it", {
  prior <- list(shape = 2, rate = 0.5)
  toy <- toy_missing()
  set.seed(1)
  sd <- stats::runif(15, 0.5, 2)
  f <- field_data(toy$y, x = toy$x, t = toy$t, sd = matrix(sd, 3, byrow = TRUE))
  ex <- posterior_exact(toy$library, f, rho_x = c(0, 0.4), rho_t = 0.5, prior = prior)
  scaled <- sim_library(lib_theta(toy$library), sweep(toy$Y, 2, sd, "/"), x = toy$x, t = toy$t)
  ex_s <- posterior_exact(scaled, field_data(toy$y / sd, x = toy$x, t = toy$t),
                          rho_x = c(0, 0.4), rho_t = 0.5, prior = prior)
  expect_equal(ex$joint, ex_s$joint, tolerance = 1e-12)
  # the evidence of y itself: the Jacobian of the scaling
  expect_equal(ex$log_evidence, ex_s$log_evidence - sum(log(sd[!is.na(toy$y)])))
  lj <- brute_log_joint(toy, rho_grid(toy$library, c(0, 0.4), 0.5), prior, sd = sd)
  expect_equal(ex$log_evidence, log_sum_exp(lj), tolerance = 1e-10)
  # with complete data too (sd alone breaks the Kronecker shortcut)
  full <- toy_missing(integer(0))
  ex_f <- posterior_exact(full$library, field_data(full$y, x = full$x, t = full$t, sd = sd[1:5]),
                          rho_t = 0.5, prior = prior)
  ex_fs <- posterior_exact(sim_library(lib_theta(full$library), sweep(full$Y, 2, rep(sd[1:5], 3), "/"),
                                       x = full$x, t = full$t),
                           field_data(full$y / rep(sd[1:5], 3), x = full$x, t = full$t),
                           rho_t = 0.5, prior = prior)
  expect_equal(ex_f$joint, ex_fs$joint, tolerance = 1e-12)
})

test_that("a correlation that makes the observed block singular is a classed error", {
  toy <- toy_missing()
  x <- data.frame(h = c(1, 1 + 1e-9, 4))
  lib <- sim_library(lib_theta(toy$library), toy$Y, x = x, t = toy$t)
  y <- toy$y
  y[1:5] <- toy$Y[1, 1:5]
  expect_error(
    local_problem(lib, field_data(y, x = x, t = toy$t), rho_x = 0.99),
    "singular", class = "griddy_error_numeric")
  # R_x is fine but two observed outputs at t 1e-12 apart are not
  lib2 <- sim_library(lib_theta(toy$library), toy$Y, x = toy$x, t = c(0, 1e-13, 0.5, 0.75, 1))
  expect_error(posterior_exact(lib2, field_data(toy$y, x = toy$x, t = lib2$t), rho_t = 0.99),
               "correlation of the observed points is numerically singular at correlation grid point 1",
               class = "griddy_error_numeric")
})

test_that("misfit_table() folds an extra log-determinant over the measurements, not the cells", {
  # it used length(y_field), counting the missing cells too
  C <- matrix(c(1, 2), 2, 1)
  extra <- matrix(c(0.5, 1), 2, 1)
  registerS3method("lib_quad_forms", "fake_library",
                   function(library, y_field, setup) list(C = C, extra_logdet = extra),
                   envir = asNamespace("griddy"))
  prior <- list(shape = 1, rate = 0.5)
  got <- misfit_table(structure(list(), class = "fake_library"), c(1, NA, 2),
                     list(group_sizes = 2), prior)$C
  expect_equal(got, fold_extra_logdet(list(C = C, extra_logdet = extra), prior, 2))
  expect_false(isTRUE(all.equal(
    c(got), c(fold_extra_logdet(list(C = C, extra_logdet = extra), prior, 3)))))
})

test_that("replicates: the posterior and evidence are those of every measurement (independent noise)", {
  prior <- list(shape = 2, rate = 0.5)
  set.seed(2)
  for (sd in list(NULL, matrix(stats::runif(30, 0.5, 2), 6))) {
    toy <- toy_replicates(sd)
    ex <- posterior_exact(toy$library, toy$field, prior = prior)
    lj <- brute_replicates(toy, prior)
    expect_equal(ex$run, exp(lj - log_sum_exp(lj)), tolerance = 1e-10)
    expect_equal(ex$log_evidence, log_sum_exp(lj), tolerance = 1e-10)
    pr <- local_problem(toy$library, toy$field, prior = prior)
    expect_identical(pr$n_obs, 28L)
    # noise groups: the pure error and its degrees of freedom go to each
    # cell's group
    by_t <- c("a", "a", "b", "b", "b")
    ex_g <- posterior_exact(toy$library, toy$field, prior = prior, noise_groups = by_t)
    lj_g <- brute_replicates(toy, prior, groups = rep(by_t, 3))
    expect_equal(ex_g$run, exp(lj_g - log_sum_exp(lj_g)), tolerance = 1e-10)
    expect_equal(ex_g$log_evidence, log_sum_exp(lj_g), tolerance = 1e-10)
    ex_x <- posterior_exact(toy$library, toy$field, prior = prior, noise_groups = "x")
    lj_x <- brute_replicates(toy, prior, groups = rep(1:3, each = 5))
    expect_equal(ex_x$log_evidence, log_sum_exp(lj_x), tolerance = 1e-10)
  }
})

test_that("replicates with correlation: R_g between the cell means, plus the pure error", {
  prior <- list(shape = 2, rate = 0.5)
  toy <- toy_replicates(matrix(seq(0.6, 1.8, length.out = 30), 6))
  pr <- local_problem(toy$library, toy$field, rho_x = 0.4, rho_t = 0.7, prior = prior)
  w <- 1 / toy$sd^2
  w[is.na(toy$y_rep)] <- 0
  y0 <- toy$y_rep
  y0[is.na(y0)] <- 0
  W <- as.vector(t(rowsum(w, toy$rows)))
  ybar <- as.vector(t(rowsum(w * y0, toy$rows))) / W
  ss <- sum(w * (y0 - matrix(ybar, 3, byrow = TRUE)[toy$rows, ])^2)
  S <- diag(1 / sqrt(W))
  R <- S %*% kronecker(corr_x(toy$x, 0.4), corr_t(toy$t, 0.7)) %*% S
  for (i in c(2, 5)) {
    r <- ybar - toy$Y[i, ]
    expect_equal(pr$C[i, 1], drop(t(r) %*% solve(R, r)) + ss)
  }
  expect_equal(pr$y_field, ybar)
  # the log-determinant: that of the means, plus the constant that makes the
  # evidence the measurements' at rho = 0
  expect_equal(pr$setup$logdet,
               as.numeric(determinant(R)$modulus) + sum(log(toy$sd[!is.na(toy$y_rep)]^2)) -
                 sum(log(1 / W)))
})

# C by the dense formula: rows of E R_g^-1 E', R_g = R_x (x) R_t, for every
# x slice of `Rx_inv` and AR(1) lag coefficients in the columns of `phi`
# (grid points in quad_forms_cpp()'s order: x slice fastest).
dense_quad_forms <- function(Y, y, Rx_inv, phi) {
  n_t <- nrow(phi) + 1L
  E <- matrix(y, nrow(Y), length(y), byrow = TRUE) - Y
  do.call(cbind, lapply(seq_len(ncol(phi)), function(gt) {
    R_t <- diag(n_t)
    for (a in seq_len(n_t)) for (b in seq_len(n_t)) {
      if (a < b) R_t[a, b] <- R_t[b, a] <- prod(phi[a:(b - 1L), gt])
    }
    vapply(seq_len(dim(Rx_inv)[3]), function(gx) {
      rowSums((E %*% kronecker(Rx_inv[, , gx], solve(R_t))) * E)
    }, numeric(nrow(Y)))
  }))
}

random_quad_form_problem <- function(n_runs, n_x, n_t, G_x, G_t, identity = 2L) {
  Rx_inv <- array(0, c(n_x, n_x, G_x))
  for (g in seq_len(G_x)) {
    A <- matrix(stats::rnorm(n_x^2), n_x)
    Rx_inv[, , g] <- if (g %in% identity) diag(n_x) else crossprod(A) / n_x + diag(n_x)
  }
  list(Y = matrix(stats::rnorm(n_runs * n_x * n_t), n_runs), y = stats::rnorm(n_x * n_t),
       Rx_inv = Rx_inv, phi = matrix(stats::runif((n_t - 1) * G_t, 0, 0.95), n_t - 1, G_t))
}

test_that("the tiled quadratic forms are the dense ones to 1e-10, on every path", {
  set.seed(15)
  # runs not a multiple of any block; n_x = 30 gives K = 465, more than one
  # pass of depth 256; 13 x slices more than two panels of 6; slices equal to
  # the identity take the shortcut; n_x = 1 and 6 outputs is R_x = I alone
  shapes <- list(c(301, 30, 1, 13, 1), c(150, 4, 3, 7, 2), c(37, 5, 1, 1, 1),
                 c(9, 1, 6, 1, 3), c(260, 3, 5, 8, 1), c(50, 7, 1, 3, 1))
  for (s in shapes) {
    p <- random_quad_form_problem(s[1], s[2], s[3], s[4], s[5])
    # a symmetric slice with no Cholesky factor takes the path for n_t > 1
    if (s[1] == 50) p$Rx_inv[, , 3] <- diag(c(1, -0.5, 1, 1, 2, 1, 1))
    want <- dense_quad_forms(p$Y, p$y, p$Rx_inv, p$phi)
    for (portable in c(FALSE, TRUE)) {
      C <- quad_forms_cpp(p$Y, p$y, p$Rx_inv, p$phi, 2L, portable)
      expect_lt(max(abs(C - want) / abs(want)), 1e-10)
    }
  }
})

test_that("C does not depend on the number of threads, bit for bit", {
  set.seed(16)
  for (s in list(c(1000, 12, 1, 9, 1), c(3000, 1, 20, 1, 2), c(700, 3, 4, 5, 2))) {
    p <- random_quad_form_problem(s[1], s[2], s[3], s[4], s[5])
    one <- quad_forms_cpp(p$Y, p$y, p$Rx_inv, p$phi, 1L)
    for (threads in 2:3) {
      expect_identical(quad_forms_cpp(p$Y, p$y, p$Rx_inv, p$phi, threads), one)
    }
  }
})

test_that("a non-finite output in any block, on any thread, is an error", {
  set.seed(17)
  p <- random_quad_form_problem(1000, 6, 1, 4, 1)
  for (row in c(1, 555, 1000)) {
    Y <- p$Y
    Y[row, 3] <- Inf
    expect_error(quad_forms_cpp(Y, p$y, p$Rx_inv, p$phi, 2L), "not finite")
  }
})

test_that("the exact posterior from C++ is the R formula's, margins and joint, any threads", {
  toy <- toy_xt(n_per_dim = 6, n_t = 5)
  weights <- c(0, stats::runif(35))  # a run of prior weight 0 (log weight -Inf)
  problem <- local_problem(toy$library, toy$field, rho_x = list(load = c(0, 0.5), speed = 0.3),
                           rho_t = c(0, 0.6), run_weights = weights)
  lj <- collapsed_log_joint(problem$C, problem$n_obs, problem$setup$logdet, problem$prior,
                            problem$log_prior_run, problem$log_prior_grid)
  joint <- exp(lj - log_sum_exp(lj))
  post <- grid_posterior(problem)
  expect_equal(post$joint, joint, tolerance = 1e-12)
  expect_equal(post$run, rowSums(joint), tolerance = 1e-12)
  expect_equal(post$grid, colSums(joint), tolerance = 1e-12)
  expect_equal(post$log_evidence, log_sum_exp(lj), tolerance = 1e-12)
  margins <- grid_posterior(problem, joint = FALSE)
  expect_null(margins$joint)
  expect_equal(margins[c("run", "grid", "log_evidence")], post[c("run", "grid", "log_evidence")],
               tolerance = 1e-14)
  withr::local_options(griddy.threads = 1)
  expect_identical(grid_posterior(problem), post)
})

test_that("grid points share a correlation class when their R_x agree to 1e-10", {
  # the first slice equal to each, as a search over all earlier slices finds
  every_pair <- function(stack) {
    cls <- seq_len(dim(stack)[3])
    for (j in seq_along(cls)[-1]) for (i in seq_len(j - 1L)) {
      if (cls[i] == i && max(abs(stack[, , i] - stack[, , j])) <= 1e-10) {
        cls[j] <- i
        break
      }
    }
    cls
  }
  set.seed(18)
  base <- array(stats::runif(4 * 4 * 5), c(4, 4, 5))
  pick <- c(1, 2, 1, 3, 2, 4, 5, 5, 1, 3)
  stack <- base[, , pick]
  stack[1, 1, 3] <- stack[1, 1, 3] + 5e-11   # within 1e-10 of slice 1
  stack[2, 2, 8] <- stack[2, 2, 8] + 1e-9    # not within 1e-10 of slice 7
  expect_identical(same_matrix_class(stack), every_pair(stack))
  expect_identical(same_matrix_class(stack), c(1L, 2L, 1L, 4L, 2L, 6L, 7L, 8L, 1L, 4L))
})

# e' R e with every product error-free (Dekker's split, up to eps^2) and the
# sum in long double: about 1e-13 relative on the cases below, where double
# precision sums lose 1e-10.
exact_quad_form <- function(e, R) {
  two_prod <- function(a, b) {
    split <- function(v) {
      big <- 134217729 * v
      hi <- big - (big - v)
      list(hi = hi, lo = v - hi)
    }
    p <- a * b
    A <- split(a)
    B <- split(b)
    list(p = p, err = ((A$hi * B$hi - p) + A$hi * B$lo + A$lo * B$hi) + A$lo * B$lo)
  }
  ee <- two_prod(rep(e, length(e)), rep(e, each = length(e)))
  hi <- two_prod(ee$p, as.vector(R))
  sum(c(hi$p, hi$err, ee$err * as.vector(R)))
}

# 54 x settings in 3-D at rho_x up to 0.9 (cond(R_x) up to 2e10, as on the
# thesis's piston locations) and smooth residuals: the terms of e' R_x^-1 e
# are large and cancel.
near_singular_case <- function(n_t) {
  set.seed(20)
  x <- data.frame(a = stats::runif(54), b = stats::runif(54), c = stats::runif(54))
  smooth <- list(sin(3 * x$a) + x$b^2, cos(2 * x$c), cos(3 * x$a) + x$c, sin(2 * x$b))
  Y <- y <- NULL
  for (t in seq_len(n_t)) {
    f <- smooth[2 * t - 1:0]
    Y <- cbind(Y, outer(stats::runif(300, 0.5, 2), f[[1]]) + outer(stats::runif(300), f[[2]]))
    y <- cbind(y, 1.2 * f[[1]] + 0.5 * f[[2]] + stats::rnorm(54, sd = 0.001))
  }
  # library order: the n_t outputs of each x setting together
  order_t <- as.vector(matrix(seq_len(54 * n_t), n_t, byrow = TRUE))
  lib <- sim_library(data.frame(k = 1:300), Y[, order_t], x = x, t = seq_len(n_t))
  setup <- correlation_setup(lib, list(a = c(0.5, 0.9), b = c(0.7, 0.9), c = 0.9), 0)
  exact <- vapply(seq_len(4), function(g) vapply(seq_len(300), function(i) {
    sum(vapply(seq_len(n_t), function(t) {
      exact_quad_form(y[, t] - Y[i, 54 * (t - 1) + 1:54], setup$Rx_inv[, , g])
    }, 0))
  }, 0), numeric(300))
  list(Y = Y[, order_t], y = as.vector(t(y)), setup = setup, exact = exact)
}

test_that("near-singular R_x, one output per x setting: whitening beats the full trace", {
  # here the full trace of R_x^-1 e e' (the code before) is 8.7e-10 off at
  # worst, the upper triangle of each with off-diagonal terms doubled 1.6e-9,
  # |e' L|^2 1.8e-10
  case <- near_singular_case(1)
  for (portable in c(FALSE, TRUE)) {
    C <- quad_forms_cpp(case$Y, case$y, case$setup$Rx_inv, case$setup$phi, 2L, portable)
    expect_lt(max(abs(C - case$exact) / case$exact), 3e-10)
  }
})

test_that("near-singular R_x, several outputs per x setting: as accurate as the full trace", {
  # the code before: 1.27e-10 off at worst; the upper triangles: 3.6e-10;
  # whole columns of W'W against R_x^-1: 1.2e-10
  case <- near_singular_case(2)
  for (portable in c(FALSE, TRUE)) {
    C <- quad_forms_cpp(case$Y, case$y, case$setup$Rx_inv, case$setup$phi, 2L, portable)
    expect_lt(max(abs(C - case$exact) / case$exact), 2e-10)
  }
})

test_that("the AR(1) whitening column by column gives ar1_whiten_rows_cpp()'s values exactly", {
  set.seed(5)
  for (dims in list(c(4, 1, 6), c(7, 3, 5), c(1, 2, 1), c(3, 3, 2))) {
    M <- matrix(rnorm(dims[1] * dims[2] * dims[3]), dims[1])
    phi <- runif(dims[3] - 1, 0, 0.95)
    expect_identical(ar1_whiten_columns_cpp(M, phi, dims[2]), ar1_whiten_rows_cpp(M, phi, dims[2]))
  }
  expect_error(ar1_whiten_columns_cpp(matrix(0, 2, 6), 0.5, 2L), "lag coefficients")
  # R_x = I (rho_x = 0) whitens over x to M itself: whiten_rows() skips the product
  M <- matrix(rnorm(24), 2)
  point <- list(Rx_chol = diag(3), phi = c(0.3, 0.2, 0.1))
  expect_identical(whiten_rows(M, point, 3L, 4L), ar1_whiten_rows_cpp(M, point$phi, 3L))
  point$Rx_chol <- chol(0.5 + diag(0.5, 3))
  A_x <- backsolve(point$Rx_chol, diag(3))
  expect_equal(whiten_rows(M, point, 3L, 4L),
               matrix(matrix(ar1_whiten_rows_cpp(M, point$phi, 3L), 8, 3) %*% A_x, 2, 12))
})

# grid_log_mass() in R, column by column: the definition the C++ follows.
grid_log_mass_r <- function(problem) {
  n <- problem$n_obs
  vapply(seq_len(ncol(problem$C)), function(g) {
    log_sum_exp(collapsed_log_lik(problem$C[, g], n, problem$setup$logdet[g], problem$prior) +
                  problem$log_prior_run + problem$log_prior_grid[g])
  }, numeric(1))
}

test_that("grid_log_mass() in C++ is the R definition, value for value", {
  ex <- griddy_example()
  problem <- calibration_problem(ex$library, ex$field, 0, c(0, 0.5), NULL, 2, NULL,
                                 discrepancy = gp_discrepancy(length_x = 1, length_t = c(0.3, 1)))
  expect_identical(grid_log_mass(problem), grid_log_mass_r(problem))
  # run weights, and a grid point whose every run is impossible
  problem$log_prior_run <- log(seq_len(nrow(problem$C)) / sum(seq_len(nrow(problem$C))))
  problem$log_prior_grid[2] <- -Inf
  expect_identical(grid_log_mass(problem), grid_log_mass_r(problem))
  expect_identical(grid_log_mass(problem)[2], -Inf)
})
