# The library emulator (R/library_emulator*.R): predictions between runs,
# their relative variance and the leave-one-out residuals.

smooth_outputs <- function(theta) {
  theta <- as.matrix(theta)
  cbind(sin(2 * theta[, 1]) + theta[, 2]^2, exp(-theta[, 1] * theta[, 2]), 3)
}

grid_library <- function(n = 7, shuffle = TRUE, f = smooth_outputs) {
  theta <- expand.grid(a = seq(0, 1, length.out = n), b = seq(-1, 1, length.out = n + 1))
  if (shuffle) theta <- theta[sample(nrow(theta)), ]
  sim_library(theta, f(theta))
}

# A library that records the rows read through lib_outputs().
counting_library <- function(lib) {
  lib$read <- new.env()
  lib$read$rows <- integer(0)
  class(lib) <- c("counting_library", class(lib))
  lib
}
registerS3method("lib_outputs", "counting_library", function(library, rows = NULL) {
  library$read$rows <- c(library$read$rows,
                         if (is.null(rows)) seq_len(lib_n_runs(library)) else rows)
  NextMethod()
}, envir = asNamespace("griddy"))

test_that("auto detects a full factorial in any row order and it is exact at its nodes", {
  set.seed(1)
  lib <- grid_library()
  em <- library_emulator(lib)
  expect_s3_class(em, "griddy_emulator")
  expect_identical(em$method, "grid")
  pred <- emulator_predict(em, lib$theta[1:20, ])
  expect_identical(pred$outputs, unname(lib$y[1:20, ]))
  expect_identical(pred$rel_var, rep(0, 20))
})

test_that("a library that is not a full factorial is not taken for a grid", {
  set.seed(1)
  lib <- grid_library()
  part <- sim_library(lib$theta[-5, ], lib$y[-5, ])
  expect_null(grid_axes(as.matrix(part$theta)))
  expect_error(library_emulator(part, method = "grid"), class = "griddy_error_input")
  expect_identical(library_emulator(part, method = "auto")$method,
                   if (requireNamespace("RobustGaSP", quietly = TRUE)) "gp" else "local")
})

test_that("grid interpolation reproduces a cubic inside the grid, on uneven nodes", {
  cubic <- function(theta) {
    a <- theta[, 1]
    b <- theta[, 2]
    c <- theta[, 3]
    cbind(a^3 - 2 * a * b^2 * c + c^3 - b^3 * c^2 + 1, a^2 * b^3 * c^3)
  }
  axes <- list(a = c(0, 0.1, 0.3, 0.35, 0.7, 1), b = c(-2, -1, 0, 0.5, 2), c = c(1, 2, 3, 5))
  theta <- as.matrix(expand.grid(axes))
  em <- library_emulator(sim_library(theta, cubic(theta)), method = "grid")
  set.seed(2)
  inner <- cbind(a = runif(50, 0.1, 0.7), b = runif(50, -1, 0.5), c = runif(50, 2, 3))
  expect_equal(emulator_predict(em, inner)$outputs, cubic(inner), tolerance = 1e-10,
               ignore_attr = TRUE)
  # near the ends of an axis the stencil has 3 nodes: close, not exact
  edge <- cbind(a = 0.05, b = -1.5, c = 4)
  expect_gt(max(abs(emulator_predict(em, edge)$outputs - cubic(edge))), 1e-6)
})

test_that("grid predictions are smooth-function accurate and rel_var grows away from nodes", {
  set.seed(3)
  em <- library_emulator(grid_library(11))
  new <- data.frame(a = runif(200), b = runif(200, -1, 1))
  pred <- emulator_predict(em, new)
  expect_lt(max(abs(pred$outputs - smooth_outputs(new))), 1e-3)
  expect_true(all(pred$rel_var >= 0 & pred$rel_var <= 1))
  mid <- emulator_predict(em, data.frame(a = c(0.05, 0.1), b = c(-0.9, -1 + 2 / 11)))$rel_var
  expect_gt(mid[1], 0.1)
  expect_identical(mid[2], 0)
})

test_that("theta_new is matched to the library's columns by name", {
  set.seed(4)
  em <- library_emulator(grid_library())
  new <- data.frame(a = c(0.2, 0.6), b = c(0.1, -0.3))
  expect_equal(emulator_predict(em, new[, c("b", "a")]), emulator_predict(em, new))
  expect_equal(emulator_predict(em, unname(as.matrix(new))), emulator_predict(em, new))
  expect_error(emulator_predict(em, data.frame(a = 0.2, z = 0.1)), class = "griddy_error_shape")
  expect_error(emulator_predict(em, cbind(0.1, 0.2, 0.3)), class = "griddy_error_shape")
  expect_error(emulator_predict(em, data.frame(a = 1.5, b = 0)), "outside the emulator's region")
})

test_that("grid leave-one-out residuals are small for a smooth function and shrink with a finer grid", {
  set.seed(5)
  fine <- emulator_loo(library_emulator(grid_library(21)))
  coarse <- emulator_loo(library_emulator(grid_library(6)))
  expect_identical(dim(fine$residuals), c(21L * 22L, 3L))
  expect_setequal(fine$rows, seq_len(21 * 22))
  rms <- function(r) sqrt(mean(r^2))
  expect_lt(rms(fine$residuals), 1e-3)
  expect_gt(rms(coarse$residuals), 10 * rms(fine$residuals))
  expect_lt(max(abs(fine$residuals[, 3])), 1e-12)
  # a node predicted from the 2 nodes on each side (the 3 nearest at an end):
  # a cubic in a is exact inside, a line in b everywhere
  theta <- expand.grid(a = 0:6, b = 1:4)
  lib <- sim_library(theta, cbind(theta$a^3 * theta$b))
  loo <- emulator_loo(library_emulator(lib, method = "grid"))
  inner <- lib$theta$a[loo$rows] %in% 2:4
  expect_equal(loo$residuals[inner, 1], rep(0, sum(inner)), tolerance = 1e-10)
  expect_gt(min(abs(loo$residuals[!inner, 1])), 1)
})

test_that("a region reads only the runs its stencils reach, and predicts as the whole library", {
  set.seed(6)
  lib <- counting_library(grid_library(21, f = function(th) smooth_outputs(th)[, 1:2]))
  region <- data.frame(a = c(0.42, 0.5), b = c(0.1, 0.2))
  em <- library_emulator(lib, region = region)
  expect_setequal(lib$read$rows, em$rows)
  # the nodes of the touching cells (4 in a: 0.40 to 0.55; 3 in b) and 2
  # beyond on each side
  expect_length(em$rows, (4 + 4) * (3 + 4))
  whole <- library_emulator(grid_library(21, f = function(th) smooth_outputs(th)[, 1:2]))
  new <- data.frame(a = runif(30, 0.42, 0.5), b = runif(30, 0.1, 0.2))
  expect_equal(emulator_predict(em, new)$outputs, emulator_predict(whole, new)$outputs)
  expect_error(emulator_predict(em, data.frame(a = 0.3, b = 0.15)), "outside")
  loo <- emulator_loo(em)
  expect_true(all(loo$rows %in% em$rows))
  expect_error(library_emulator(lib, region = data.frame(a = c(2, 3), b = c(0, 1))),
               "outside the library's range")
  expect_error(library_emulator(lib, region = data.frame(a = c(0.5, 0.4), b = c(0, 1))),
               "lower bounds")
})

test_that("local regression predicts a smooth function, returns runs at runs, and leaves one out", {
  set.seed(7)
  theta <- data.frame(a = runif(300), b = runif(300, -1, 1))
  lib <- counting_library(sim_library(theta, smooth_outputs(theta)))
  em <- library_emulator(lib, method = "local")
  expect_identical(em$method, "local")
  new <- data.frame(a = runif(100, 0.1, 0.9), b = runif(100, -0.8, 0.8))
  pred <- emulator_predict(em, new)
  expect_lt(sqrt(mean((pred$outputs - smooth_outputs(new))^2)), 2e-3)
  expect_true(all(pred$rel_var > 0 & pred$rel_var <= 1))
  at_runs <- emulator_predict(em, theta[1:5, ])
  expect_identical(at_runs$outputs, unname(lib$y[1:5, ]))
  expect_identical(at_runs$rel_var, rep(0, 5))
  loo <- emulator_loo(em)
  expect_identical(dim(loo$residuals), c(300L, 3L))
  expect_lt(sqrt(mean(loo$residuals^2)), 0.01)
  coarse <- library_emulator(sim_library(theta[1:40, ], smooth_outputs(theta[1:40, ])),
                             method = "local")
  expect_gt(sqrt(mean(emulator_loo(coarse)$residuals^2)), 3 * sqrt(mean(loo$residuals^2)))
  # a region: only runs near it are read
  lib$read$rows <- integer(0)
  em <- library_emulator(lib, region = data.frame(a = c(0.4, 0.5), b = c(0, 0.2)),
                         method = "local")
  expect_setequal(lib$read$rows, em$rows)
  expect_lt(length(em$rows), 100)
  new <- data.frame(a = runif(20, 0.4, 0.5), b = runif(20, 0, 0.2))
  expect_lt(max(abs(emulator_predict(em, new)$outputs - smooth_outputs(new))), 2e-3)
})

test_that("gp predicts a smooth function, with rel_var 0 at runs and constant outputs kept", {
  skip_if_not_installed("RobustGaSP")
  set.seed(8)
  theta <- data.frame(a = runif(60), b = runif(60, -1, 1))
  lib <- sim_library(theta, smooth_outputs(theta))
  em <- library_emulator(lib, method = "gp")
  expect_identical(em$method, "gp")
  new <- data.frame(a = runif(50, 0.1, 0.9), b = runif(50, -0.8, 0.8))
  pred <- emulator_predict(em, new)
  expect_lt(max(abs(pred$outputs - smooth_outputs(new))), 1e-2)
  expect_identical(pred$outputs[, 3], rep(3, 50))
  expect_true(all(pred$rel_var >= 0 & pred$rel_var <= 1))
  expect_gt(max(pred$rel_var), 0.05)
  at_runs <- emulator_predict(em, theta[1:4, ])
  expect_identical(at_runs$rel_var, rep(0, 4))
  expect_equal(at_runs$outputs, unname(lib$y[1:4, ]), tolerance = 1e-6)
})

test_that("gp leave-one-out residuals match a refit without the run", {
  skip_if_not_installed("RobustGaSP")
  set.seed(9)
  theta <- data.frame(a = runif(40), b = runif(40, -1, 1))
  lib <- counting_library(sim_library(theta, smooth_outputs(theta)))
  em <- library_emulator(lib, method = "gp", max_runs = 30)
  expect_length(em$rows, 30)
  expect_setequal(lib$read$rows, em$rows)
  loo <- emulator_loo(em)
  expect_identical(loo$rows, em$rows)
  expect_identical(loo$residuals[, 3], rep(0, 30))
  x <- gp_inputs(em, em$u)
  i <- 7
  refit <- NULL
  utils::capture.output(refit <- RobustGaSP::ppgasp(x[-i, ], em$y[-i, 1:2],
                                                    range.par = 1 / em$fit@beta_hat))
  direct <- em$y[i, 1:2] - RobustGaSP::predict.ppgasp(refit, x[i, , drop = FALSE])$mean
  expect_equal(loo$residuals[i, 1:2], c(direct), tolerance = 1e-4)
  expect_lt(sqrt(mean(loo$residuals^2)), 0.05)
})

test_that("gp on a region fits the runs nearest it", {
  skip_if_not_installed("RobustGaSP")
  set.seed(10)
  theta <- data.frame(a = runif(500), b = runif(500, -1, 1))
  lib <- counting_library(sim_library(theta, smooth_outputs(theta)))
  region <- data.frame(a = c(0.3, 0.5), b = c(-0.2, 0.2))
  em <- library_emulator(lib, region = region, method = "gp", max_runs = 50)
  expect_setequal(lib$read$rows, em$rows)
  inside <- theta$a >= 0.3 & theta$a <= 0.5 & abs(theta$b) <= 0.2
  expect_true(all(which(inside) %in% em$rows))
  new <- data.frame(a = runif(20, 0.3, 0.5), b = runif(20, -0.2, 0.2))
  expect_lt(max(abs(emulator_predict(em, new)$outputs - smooth_outputs(new))), 1e-3)
})

test_that("more runs inside the region than max_runs gives a spread-out subset", {
  set.seed(11)
  u <- matrix(runif(2000), 1000)
  box <- rbind(c(0, 0), c(1, 1))
  rows <- runs_for_region(u, box, 50)
  expect_length(unique(rows), 50)
  # every part of the box is near a chosen run
  probe <- halton_in_box(200, box)
  expect_lt(max(nearest_runs(probe, u[rows, ], 1)$dist), 0.25)
})

test_that("a gp predictive variance that ppgasp cannot give counts as the largest", {
  skip_if_not_installed("RobustGaSP")
  set.seed(4)
  theta <- data.frame(a = runif(30), b = runif(30))
  y <- t(vapply(seq_len(30), function(i) sin(3 * theta$a[i]) + theta$b[i] * (1:5), numeric(5)))
  lib <- sim_library(theta, y)
  em <- suppressWarnings(library_emulator(lib, method = "gp"))
  em$var_max <- NA_real_          # what a near-singular fit gave on the projectile
  pred <- emulator_predict(em, data.frame(a = c(0.31, 0.52), b = c(0.44, 0.27)))
  expect_equal(pred$rel_var, c(1, 1))
  expect_true(all(is.finite(pred$outputs)))
})

test_that("auto on a dense region keeps a GP on a quarter of max_runs only if held-out runs confirm it", {
  skip_if_not_installed("RobustGaSP")
  set.seed(3)
  theta <- data.frame(a = runif(400), b = runif(400))
  region <- data.frame(a = c(0.2, 0.8), b = c(0.2, 0.8))
  # smooth outputs: the small GP predicts the region's other runs closely and is kept
  smooth <- sim_library(theta, cbind(theta$a + 2 * theta$b, theta$a - theta$b))
  em <- library_emulator(smooth, region, max_runs = 60)
  expect_identical(em$method, "gp")
  expect_length(em$rows, 15L)
  inside <- which(theta$a >= 0.2 & theta$a <= 0.8 & theta$b >= 0.2 & theta$b <= 0.8)
  held <- setdiff(inside, em$rows)
  err <- emulator_predict(em, theta[held, ])$outputs - lib_outputs(smooth, held)
  expect_lt(sqrt(mean(err^2)), 1e-3 * sd(as.vector(lib_outputs(smooth, held))))
  # outputs that vary faster than 15 runs resolve: the GP on max_runs runs, as method "gp"
  rough <- sim_library(theta, cbind(sin(30 * theta$a) * cos(25 * theta$b), theta$b))
  em <- library_emulator(rough, region, max_runs = 60)
  expect_length(em$rows, 60L)
  expect_identical(em$rows, library_emulator(rough, region, method = "gp", max_runs = 60)$rows)
  # a sparse region (fewer than max_runs / 2 runs inside): unchanged
  em <- library_emulator(smooth, region, max_runs = 400)
  expect_length(em$rows, 400L)
})
