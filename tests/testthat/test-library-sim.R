test_that("sim_library keeps what was given and fills t", {
  theta <- data.frame(k = 1:4, c = c(0.1, 0.2, 0.1, 0.2))
  y <- matrix(seq_len(24), 4, 6)
  lib <- sim_library(theta, y, x = data.frame(h = c(1, 2)))
  expect_s3_class(lib, "sim_library")
  expect_identical(lib$theta$k, as.double(1:4))
  expect_identical(lib$y, y * 1.0)
  expect_identical(lib$t, c(1, 2, 3))
  expect_identical(lib_n_x(lib), 2L)
  expect_identical(lib_n_t(lib), 3L)
  expect_output(print(lib), "4 runs of 2 parameter")
  expect_output(print(lib), "2 setting\\(s\\) of h")
})

test_that("sim_library accepts a named matrix theta and a vector x", {
  theta <- cbind(k = 1:3)
  lib <- sim_library(theta, matrix(1:6, 3), x = c(5, 6))
  expect_identical(names(lib$x), "x")
  expect_identical(lib_n_t(lib), 1L)
})

test_that("sim_library rejects bad input with clear errors", {
  y <- matrix(1:8, 4)
  expect_error(sim_library(list(k = 1:4), y), "`theta` must be a data.frame")
  expect_error(sim_library(matrix(1:4), y), "name for every column")
  expect_error(sim_library(data.frame(k = 1), matrix(1:2, 1)), "at least 2 runs")
  expect_error(sim_library(data.frame(k = 1:4), y[1:3, ]), "`theta` has 4 rows but `y` has 3")
  expect_error(sim_library(data.frame(k = c(1, 2, NA, 4)), y), "`theta` must hold finite numbers; found NA at \\[3, k\\]")
  expect_error(sim_library(data.frame(k = letters[1:4]), y), "column\\(s\\) k are character")
  expect_error(sim_library(data.frame(k = 1:4), y, x = data.frame(h = 1:3)), "not a multiple of the 3 x settings")
  expect_error(sim_library(data.frame(k = 1:4), y, x = data.frame(h = c(1, 1))), "duplicated settings at row\\(s\\) 2")
  expect_error(sim_library(data.frame(k = 1:4), y, t = 1:3), "2 `y` columns per x setting but `t` has 3")
  expect_error(sim_library(data.frame(k = 1:4), y, t = c(2, 1)), "strictly increasing")
  expect_error(sim_library(data.frame(k = c(1, 2, 1, 3)), y), "duplicated runs: row\\(s\\) 3 repeat row\\(s\\) 1")
  bad_y <- y * 1.0
  bad_y[2, 2] <- NaN
  expect_error(sim_library(data.frame(k = 1:4), bad_y), "`y` must hold finite numbers; found NaN at \\[2, 2\\]")
})

test_that("a constant theta column is a warning, not an error", {
  expect_warning(sim_library(data.frame(k = 1:3, c = 1), matrix(1:6, 3)), "column\\(s\\) c are constant")
})

test_that("integer and integer64 x settings are stored as plain doubles", {
  skip_if_not_installed("bit64")
  x <- data.frame(load = bit64::as.integer64(c(3000000000, 3000000001)), speed = 1:2)
  lib <- sim_library(data.frame(k = 1:3), matrix(1:12, 3), x = x)
  expect_identical(lib$x, data.frame(load = c(3e9, 3e9 + 1), speed = c(1, 2)))
})

test_that("a library of 0 or 1 runs is a classed error saying how many (issue 22)", {
  err <- expect_error(sim_library(data.frame(k = numeric(0)), matrix(numeric(0), 0, 3)),
                      class = "griddy_error_library_size")
  expect_match(conditionMessage(err), "`theta` holds 0 runs.*at least 2")
  expect_error(sim_library(matrix(numeric(0), 0, 1, dimnames = list(NULL, "k")),
                           matrix(numeric(0), 0, 3)), "holds 0 runs",
               class = "griddy_error_library_size")
  expect_error(sim_library(data.frame(k = 1), matrix(1:3, 1)), "holds 1 run",
               class = "griddy_error_library_size")
})

test_that("print.sim_library() shows runs, parameters, settings and outputs", {
  expect_snapshot(print(toy_xt(n_per_dim = 4)$library))
  expect_snapshot(print(toy_ar1(n_runs = 30, n_t = 5)$library))
})

test_that("an x column named like a column of griddy's tables is refused (issue 33)", {
  # before, `t` as an x column gave predict() two columns named t, and the
  # ppc plot read the output coordinate from the wrong one
  theta <- data.frame(a = 1:3)
  y <- matrix(1:6, 3, 2)
  for (name in c("t", "mean", "observed")) {
    x <- stats::setNames(data.frame(c(1, 2)), name)
    expect_error(sim_library(theta, y, x = x), paste0("`", name, "`"),
                 class = "griddy_error_input")
  }
  # `x` itself is allowed (the setting's row is then named `setting`)
  expect_s3_class(sim_library(theta, y, x = data.frame(x = c(1, 2))), "sim_library")
})
