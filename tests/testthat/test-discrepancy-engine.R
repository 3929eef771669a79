# The discrepancy through low-rank kernel factors (discrepancy-engine.R)
# against the definition: C = r' (S R S + lambda K)^-1 r and its
# log-determinant by dense solves over the observed points.

engine_case <- function(missing = FALSE, sd = NULL) {
  set.seed(3)
  n_t <- 12
  x <- data.frame(load = c(1, 2, 3))
  t <- seq(0, 1, length.out = n_t)
  theta <- expand.grid(a = seq(0.5, 1.5, length.out = 6), b = seq(0, 1, length.out = 5))
  sim <- function(a, b) {
    do.call(cbind, lapply(x$load, function(l) outer(a * l, sin(3 * t)) + outer(b, cos(2 * t) * l)))
  }
  lib <- sim_library(theta, sim(theta$a, theta$b), x = x, t = t)
  y <- matrix(drop(sim(1, 0.4)) + 0.1 * rep(t^2, 3) + rnorm(3 * n_t, sd = 0.05), 3, byrow = TRUE)
  if (missing) y[2, 5] <- NA
  list(lib = lib, field = field_data(y, x = x, t = t, sd = sd), t = t)
}

# C (runs x grid points) and log-determinants by dense solves.
brute_forms <- function(lib, y, setup) {
  disc <- setup$discrepancy
  K <- discrepancy_kernels(lib, attr(disc, "kernels"))
  obs <- setup$dense$obs
  s <- if (is.null(setup$dense$scale)) rep(1, length(obs)) else 1 / setup$dense$scale
  Y <- lib_outputs(lib, seq_len(lib_n_runs(lib)))
  r <- t(matrix(y[obs], nrow(Y), length(obs), byrow = TRUE) - Y[, obs])
  out <- lapply(seq_along(setup$gd), function(j) {
    R_x <- crossprod(setup$Rx_chol[, , setup$gx[j]])
    S <- kronecker(R_x, corr_t(lib_t(lib), setup$rho_t[setup$gt[j]]))[obs, obs] * outer(s, s)
    d <- disc[setup$gd[j], ]
    if (d$ratio > 0) S <- S + d$ratio * K[[d$kernel]][obs, obs]
    list(C = colSums(r * solve(S, r)), logdet = as.numeric(determinant(S)$modulus))
  })
  list(C = sapply(out, `[[`, "C"), logdet = sapply(out, `[[`, "logdet"))
}

expect_forms_exact <- function(case, discrepancy) {
  problem <- calibration_problem(case$lib, case$field, 0, c(0, 0.5, 0.9), NULL, 2, NULL,
                                 discrepancy = discrepancy)
  setup <- problem$setup
  expect_true(setup$dense$lowrank)
  ref <- brute_forms(case$lib, problem$y_field, setup)
  C <- plain_quad_forms(lib_outputs(case$lib, seq_len(lib_n_runs(case$lib))), problem$y_field,
                        setup)
  expect_lt(max(abs(C - ref$C) / ref$C), 1e-8)
  # the replicates' constant aside, log-determinants differ by one constant
  dl <- setup$logdet - ref$logdet
  expect_lt(max(abs(dl - dl[1])), 1e-7)
  # grid_point()'s factor A: A A' is the inverse covariance
  r <- (problem$y_field - lib_outputs(case$lib, 7)[1, ])[setup$dense$obs]
  if (!is.null(setup$dense$scale)) r <- r * setup$dense$scale
  for (j in c(1L, 5L, length(setup$gd))) {
    A <- grid_point(setup, j)$dense$A[[1]]
    expect_equal(sum((r %*% A)^2), ref$C[7, j], tolerance = 1e-8)
    # one grid point's forms (group_quad_forms()) are the table's
    Y <- lib_outputs(case$lib, 1:4)
    expect_equal(drop(group_quad_forms(Y, problem$y_field, setup, j)), C[1:4, j],
                 tolerance = 1e-10)
  }
  problem
}

test_that("the low-rank quadratic forms match dense solves for every kind of discrepancy", {
  case <- engine_case()
  expect_forms_exact(case, gp_discrepancy())
  expect_forms_exact(case, gp_discrepancy(orthogonal = FALSE))
  expect_forms_exact(case, gp_discrepancy(scaled = TRUE))
  expect_forms_exact(case, gp_discrepancy(zero_at = data.frame(load = 0, t = case$t)))
})

test_that("the low-rank quadratic forms match dense solves with a missing cell and sd", {
  expect_forms_exact(engine_case(missing = TRUE), gp_discrepancy())
  sd <- matrix(seq(0.5, 2, length.out = 36), 3)
  expect_forms_exact(engine_case(sd = sd), gp_discrepancy(orthogonal = FALSE))
})

test_that("delta's law from the factors matches the full law", {
  case <- engine_case()
  problem <- calibration_problem(case$lib, case$field, 0, c(0, 0.5, 0.9), NULL, 2, NULL,
                                 discrepancy = gp_discrepancy())
  setup <- problem$setup
  K <- discrepancy_kernels(case$lib, attr(setup$discrepancy, "kernels"))
  # kernels one output longer than the library's take the full law
  # (predict() at new settings), with grid_point()'s factor A
  K_long <- lapply(K, function(M) {
    out <- matrix(0, nrow(M) + 1, nrow(M) + 1)
    out[seq_len(nrow(M)), seq_len(nrow(M))] <- M
    out
  })
  resid <- run_residuals(list(y_field = problem$y_field, library = case$lib), 1:5)
  n <- ncol(resid)
  for (j in c(15L, 40L, length(setup$gd))) {
    low <- delta_law(setup, j, K)
    full <- delta_law(setup, j, K_long)
    expect_false(is.null(low$groups[[1]]$L))
    expect_true(is.null(full$groups[[1]]$L))
    m_full <- delta_means(full, cbind(resid, 0))[, seq_len(n)]
    expect_lt(max(abs(delta_means(low, resid) - m_full)), 1e-8 * max(abs(m_full)))
    P_full <- delta_cov(full$groups[[1]])
    expect_lt(max(abs(delta_cov(low$groups[[1]]) - P_full[seq_len(n), seq_len(n)])),
              1e-7 * max(abs(P_full)))
  }
})

test_that("tiled_matmul_cpp() is the matrix product, on any shape and thread count", {
  set.seed(1)
  for (dims in list(c(1, 1, 1), c(7, 5, 3), c(130, 300, 13), c(257, 17, 61))) {
    X <- matrix(rnorm(dims[1] * dims[2]), dims[1])
    B <- matrix(rnorm(dims[2] * dims[3]), dims[2])
    expect_equal(tiled_matmul_cpp(X, B, 1L), X %*% B, tolerance = 1e-12)
    expect_identical(tiled_matmul_cpp(X, B, 2L), tiled_matmul_cpp(X, B, 1L))
  }
})

# Predicted runs' forms with a discrepancy: C = r' (S R S + lambda K + kappa_i
# U diag(lambda_e / s2_k) U')^-1 r per noise group (folded) and the error's
# extra log-determinant, by dense solves.
brute_emulated_forms <- function(lib, y, setup, err, kappa) {
  disc <- setup$discrepancy
  K <- discrepancy_kernels(lib, attr(disc, "kernels"))
  obs <- setup$dense$obs
  groups <- setup$dense$groups
  s <- if (is.null(setup$dense$scale)) rep(1, length(obs)) else 1 / setup$dense$scale
  s2 <- rep_len(err$noise_var, length(groups))
  Y <- lib_outputs(lib, seq_len(lib_n_runs(lib)))
  r <- t(matrix(y[obs], nrow(Y), length(obs), byrow = TRUE) - Y[, obs])
  U <- err$U[obs, , drop = FALSE]
  C <- matrix(0, nrow(Y), length(setup$gd))
  extra <- C
  for (j in seq_along(setup$gd)) {
    R_x <- crossprod(setup$Rx_chol[, , setup$gx[j]])
    S <- kronecker(R_x, corr_t(lib_t(lib), setup$rho_t[setup$gt[j]]))[obs, obs] * outer(s, s)
    d <- disc[setup$gd[j], ]
    if (d$ratio > 0) S <- S + d$ratio * K[[d$kernel]][obs, obs]
    for (i in seq_len(nrow(Y))) {
      Ck <- vapply(seq_along(groups), function(k) {
        idx <- groups[[k]]
        V <- U[idx, , drop = FALSE] %*% (err$lambda / s2[k] * t(U[idx, , drop = FALSE]))
        Sk <- S[idx, idx] + kappa[i] * V
        extra[i, j] <<- extra[i, j] + as.numeric(determinant(Sk)$modulus) -
          as.numeric(determinant(S[idx, idx])$modulus)
        sum(r[idx, i] * solve(Sk, r[idx, i])) + setup$pure_ss[k]
      }, 0)
      C[i, j] <- fold_groups(matrix(Ck, 1), setup)
    }
  }
  list(C = C, logdet = extra)
}

expect_emulated_exact <- function(case, discrepancy, noise_var, noise_groups = NULL) {
  problem <- calibration_problem(case$lib, case$field, 0, c(0, 0.5, 0.9), NULL, 2, NULL,
                                 noise_groups = noise_groups, discrepancy = discrepancy)
  setup <- problem$setup
  set.seed(5)
  n_out <- lib_n_out(case$lib)
  err <- list(U = qr.Q(qr(matrix(rnorm(n_out * 4), n_out))),
              lambda = c(0.02, 0.01, 0.004, 0.001), noise_var = noise_var)
  kappa <- c(0, stats::runif(lib_n_runs(case$lib) - 1, 0, 3))
  Y <- lib_outputs(case$lib, seq_len(lib_n_runs(case$lib)))
  ref <- brute_emulated_forms(case$lib, problem$y_field, setup, err, kappa)
  got <- emulated_quad_forms(Y, problem$y_field, setup, err, kappa, lib_n_x(case$lib),
                             lib_n_t(case$lib))
  expect_lt(max(abs(got$C - ref$C) / ref$C), 1e-8)
  expect_lt(max(abs(got$logdet - ref$logdet)), 1e-8 * max(1, abs(ref$logdet)))
  # one grid point's group forms (emulated_group_forms()) are the table's
  for (j in c(1L, 7L, length(setup$gd))) {
    one <- emulated_group_forms(Y, problem$y_field, setup, err, kappa, lib_n_x(case$lib),
                                lib_n_t(case$lib), j)
    expect_equal(fold_groups(one$C, setup), got$C[, j], tolerance = 1e-10)
    expect_equal(one$logdet, got$logdet[, j], tolerance = 1e-10)
  }
}

test_that("predicted runs' forms under a discrepancy match dense solves", {
  case <- engine_case()
  expect_emulated_exact(case, gp_discrepancy(), 0.0025)
  expect_emulated_exact(case, gp_discrepancy(scaled = TRUE, orthogonal = FALSE), 0.0025)
})

test_that("predicted runs' forms under a discrepancy match dense solves with gaps, sd and groups", {
  expect_emulated_exact(engine_case(missing = TRUE), gp_discrepancy(), 0.0025)
  sd <- matrix(seq(0.5, 2, length.out = 36), 3)
  expect_emulated_exact(engine_case(missing = TRUE, sd = sd), gp_discrepancy(),
                        c(0.002, 0.004), noise_groups = rep(c("a", "b"), 18))
})

test_that("complete data and Kronecker kernels take the per-axis coordinates, to rounding", {
  case <- engine_case()
  problem <- calibration_problem(case$lib, case$field, 0, c(0, 0.5, 0.9), NULL, 2, NULL,
                                 discrepancy = gp_discrepancy(orthogonal = FALSE))
  setup <- problem$setup
  expect_false(is.null(setup$dense$axis_rot))
  Y <- lib_outputs(case$lib, seq_len(lib_n_runs(case$lib)))
  C <- plain_quad_forms(Y, problem$y_field, setup)
  # the same rotations through the whole whitened basis
  whole <- setup
  whole$dense$axis_rot <- NULL
  expect_lt(max(abs(C - plain_quad_forms(Y, problem$y_field, whole)) / C), 1e-10)
  # a projected (orthogonal) or scaled kernel is no Kronecker product, but its
  # basis's leading columns are: the residuals' coordinates in it per axis
  for (disc in list(gp_discrepancy(), gp_discrepancy(scaled = TRUE))) {
    other <- calibration_problem(case$lib, case$field, 0, c(0, 0.5), NULL, 2, NULL,
                                 discrepancy = disc)
    expect_null(other$setup$dense$axis_rot)
    expect_false(is.null(other$setup$dense$axis_basis))
    C <- plain_quad_forms(Y, other$y_field, other$setup)
    whole <- other$setup
    whole$dense$axis_basis <- NULL
    expect_lt(max(abs(C - plain_quad_forms(Y, other$y_field, whole)) / C), 1e-10)
  }
})

test_that("block_transpose_cpp() regroups blocks of runs as aperm() does, value for value", {
  set.seed(2)
  runs <- 5L
  a <- 3L
  b <- 4L
  X <- matrix(rnorm(runs * a * (b + 2)), runs * a)
  ref <- function(M) matrix(aperm(array(M, c(runs, a, ncol(M))), c(1L, 3L, 2L)),
                            runs * ncol(M), a)
  expect_identical(block_transpose_cpp(X, runs, a, b + 2L, 0L), ref(X))
  # from column 2 on: the columns' blocks alone
  expect_identical(block_transpose_cpp(X, runs, a, b, 2L), ref(X[, 3:6]))
  # a matrix read by its length, whatever its dimensions: runs x (a b)
  Z <- matrix(rnorm(runs * a * b), runs)
  expect_identical(setting_rows(Z, runs, b, a),
                   matrix(aperm(array(Z, c(runs, a, b)), c(1L, 3L, 2L)), runs * b, a))
  expect_error(block_transpose_cpp(X, runs, a, b + 3L, 0L), "do not fit")
})

test_that("the whitened basis's Gram matrix per axis is the dense crossprod, to rounding", {
  case <- engine_case()
  for (disc in list(gp_discrepancy(), gp_discrepancy(scaled = TRUE))) {
    problem <- calibration_problem(case$lib, case$field, 0, c(0, 0.7), NULL, 2, NULL,
                                   discrepancy = disc)
    dense <- problem$setup$dense
    for (g in seq_along(dense$H)) {
      H <- dense$H[[g]][[1]]
      J <- kron_gram(H, dense$axis_basis[[g]], function(X, B) X %*% B)
      expect_lt(max(abs(J - crossprod(H))), 1e-12 * max(abs(J)))
      # every kernel's rotation diagonalises C' H'H C: G = H T has G'G = diag(d)
      for (r in dense$rot[[g]]) {
        G <- H %*% r[[1]]$T
        expect_lt(max(abs(crossprod(G) - diag(r[[1]]$d, length(r[[1]]$d)))),
                  1e-10 * max(r[[1]]$d))
      }
    }
  }
})
