test_that("rho_grid lists every combination, x columns varying fastest", {
  toy <- toy_xt()
  g <- rho_grid(toy$library, rho_x = list(load = c(0, 0.5), speed = 0.2), rho_t = c(0, 0.3, 0.6))
  expect_identical(names(g), c("rho_x_load", "rho_x_speed", "rho_t"))
  expect_identical(nrow(g), 6L)
  expect_identical(g$rho_x_load, rep(c(0, 0.5), 3))
  expect_identical(g$rho_t, rep(c(0, 0.3, 0.6), each = 2))
  expect_identical(nrow(rho_grid(toy$library, rho_x = c(0, 0.5))), 4L)
})

test_that("rho grids are validated", {
  toy <- toy_xt()
  expect_error(rho_grid(toy$library, rho_x = list(0.1)), "one grid per x column \\(load, speed\\); received 1")
  expect_error(rho_grid(toy$library, rho_x = list(a = 0, b = 0)), "must be the x columns")
  expect_error(rho_grid(toy$library, rho_t = 1.2), "`rho_t` must lie in \\[0, 1\\)")
  one <- toy_ar1(n_runs = 5, n_t = 4)
  expect_error(rho_grid(one$library, rho_x = 0.5), "single x setting")
  lib1 <- sim_library(data.frame(k = 1:2), matrix(1:4, 2), x = data.frame(h = 1:2))
  expect_error(rho_grid(lib1, rho_t = 0.5), "single output per x setting")
  expect_error(rho_grid(list(), 0), "must be a sim_library")
})

test_that("R_x follows eq. 3.14 (power 2) and eq. 5 (power 1)", {
  x <- data.frame(a = c(0, 5, 10), b = c(1, 1, 3))
  R2 <- corr_x(x, c(0.8, 0.5), power = 2)
  expect_equal(R2[1, 2], 0.8^(4 * 0.5^2) * 0.5^0)
  expect_equal(R2[1, 3], 0.8^4 * 0.5^4)
  R1 <- corr_x(x, c(0.8, 0.5), power = 1)
  expect_equal(R1[1, 2], 0.8^0.5)
  expect_identical(corr_x(x, c(0, 0)), diag(3))
  expect_identical(corr_x(NULL, 0.3), matrix(1))
})

test_that("the AR(1) log-determinant matches dense algebra, even and uneven t", {
  for (t in list(seq(0, 1, length.out = 7), c(0, 0.1, 0.15, 0.5, 0.9, 1))) {
    for (rho in c(0, 0.3, 0.9)) {
      phi <- ar1_phi(t, rho)
      R <- corr_t(t, rho)
      expect_equal(sum(log1p(-phi^2)), as.numeric(determinant(R)$modulus))
    }
  }
  # eq. 11: on an even grid of step eps, log|R_t| = (n_t - 1) log(1 - rho^(2 eps))
  phi <- ar1_phi(1:11, 0.4)
  expect_equal(sum(log1p(-phi^2)), 10 * log(1 - 0.4^(2 * 0.1)))
})

test_that("quadratic forms and log-determinants match the dense Kronecker product", {
  # 17 x 17 = 289 runs: more than one block of 256 runs in quad_forms_cpp()
  toy <- toy_xt(n_per_dim = 17, n_t = 5)
  lib <- toy$library
  lib$t <- c(0, 0.2, 0.3, 1.1, 2) # uneven spacing
  toy$field$t <- NULL
  y <- field_vector(lib, toy$field)
  setup <- correlation_setup(lib, rho_x = list(load = c(0, 0.6), speed = 0.3),
                             rho_t = c(0, 0.5), x_power = 2)
  C <- misfit_table(lib, y, setup, thesis_prior())$C
  expect_identical(dim(C), c(289L, 4L))
  grid <- rho_grid(lib, rho_x = list(load = c(0, 0.6), speed = 0.3), rho_t = c(0, 0.5))
  for (g in seq_len(nrow(grid))) {
    gr <- grid[g, ]
    R <- kronecker(corr_x(lib$x, c(gr$rho_x_load, gr$rho_x_speed)), corr_t(lib$t, gr$rho_t))
    Rinv <- solve(R)
    dense <- apply(lib$y, 1, function(run) drop(crossprod(y - run, Rinv %*% (y - run))))
    expect_equal(C[, g], dense, tolerance = 1e-9)
    expect_equal(setup$logdet[g], as.numeric(determinant(R)$modulus), tolerance = 1e-9)
  }
})

test_that("singular R_x and bad x_power are reported", {
  lib <- sim_library(data.frame(k = 1:2), matrix(1:6, 2), x = data.frame(h = c(0, 1e-9, 1)))
  expect_error(correlation_setup(lib, rho_x = 0.99, rho_t = 0), "R_x is numerically singular at rho_x_h = 0.99")
  expect_error(correlation_setup(lib, 0, 0, x_power = 3), "`x_power` must be a single number in \\(0, 2\\]")
})

test_that("corr_x_grid() gives corr_x() at every combination, in expand.grid() order", {
  x <- data.frame(a = c(0, 0.3, 1, 0.5), b = c(2, 1, 1, 0), c = c(5, 5, 6, 7))
  grids <- list(a = c(0, 0.4), b = c(0.2, 0.7, 0.9), c = 0.5)
  combos <- expand.grid(grids)
  for (power in c(1, 2)) {
    R <- corr_x_grid(x, grids, power)
    expect_length(R, nrow(combos))
    for (k in seq_len(nrow(combos))) {
      expect_identical(R[[k]], corr_x(x, unlist(combos[k, ]), power))
    }
  }
  expect_identical(corr_x_grid(NULL, list(x = 0)), list(matrix(1)))
})
