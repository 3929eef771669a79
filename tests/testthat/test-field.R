test_that("field_data shapes vectors and matrices", {
  f <- field_data(1:6, x = data.frame(h = 1:2))
  expect_identical(f$y, matrix(c(1, 4, 2, 5, 3, 6), 2))
  expect_identical(dim(field_data(1:6, t = 1:3)$y), c(2L, 3L))
  expect_identical(dim(field_data(1:6)$y), c(1L, 6L))
  expect_output(print(f), "6 measurement")
})

test_that("field_data rejects inconsistent input", {
  expect_error(field_data(1:5, x = data.frame(h = 1:2)), "do not split into 2 x settings")
  expect_error(field_data(matrix(1:6, 3), x = data.frame(h = 1:2)), "`x` has 2 rows but `y` has 3")
  expect_error(field_data(matrix(1:6, 2), t = 1:4), "`t` has 4")
  expect_error(field_data(c(1, Inf)), "found Inf")
  expect_error(field_data(c(NA, NA)), "every value is NA")
})

test_that("field_vector puts field data in the library's order", {
  lib <- sim_library(data.frame(k = 1:2), matrix(1:12, 2),
                     x = data.frame(h = c(10, 20, 30)), t = c(0, 1))
  f <- field_data(rbind(c(5, 6), c(1, 2), c(3, 4)), x = data.frame(h = c(30, 10, 20)), t = c(0, 1))
  expect_identical(field_vector(lib, f), c(1, 2, 3, 4, 5, 6))
  expect_identical(field_vector(lib, field_data(1:6)), as.double(1:6))
})

test_that("field_vector rejects fields that do not match the library", {
  lib <- sim_library(data.frame(k = 1:2), matrix(1:12, 2),
                     x = data.frame(h = c(10, 20, 30)), t = c(0, 1))
  expect_error(field_vector(lib, field_data(1:4)), "4 measurements but the library has 3 x setting\\(s\\) x 2 output\\(s\\) = 6")
  expect_error(field_vector(lib, field_data(matrix(1:6, 3), t = c(0, 2))),
               "field coordinate\\(s\\) 2 \\(position\\(s\\) 2\\) are not among the library's")
  expect_error(field_vector(lib, field_data(matrix(1:6, 3), x = data.frame(v = 1:3))), "column\\(s\\) v but the library's x has h")
  expect_error(field_vector(lib, field_data(matrix(1:6, 3), x = data.frame(h = c(10, 20, 40)))),
               "x setting\\(s\\) at row\\(s\\) 3 that the library does not have")
  expect_error(field_vector(lib, field_data(matrix(1:8, 4), x = data.frame(h = c(10, 20, 30, 40)))),
               "x setting\\(s\\) at row\\(s\\) 4 that the library does not have")
  expect_error(calibrate(list(), field_data(1)), "`library` must be a sim_library")
  expect_error(field_vector(lib, 1:6), "`field` must be a griddy_field")
})

test_that("a vector y with both x and t must hold n_x * n_t values", {
  expect_error(field_data(1:6, x = data.frame(h = 1:3), t = 1:3),
               "`y` has 6 values but `x` has 3 settings and `t` 3 coordinates: 3 x 3 = 9 expected",
               class = "griddy_error_input")
  expect_error(field_data(1:12, x = data.frame(h = 1:3), t = 1:3), "3 x 3 = 9 expected")
  expect_identical(dim(field_data(1:9, x = data.frame(h = 1:3), t = 1:3)$y), c(3L, 3L))
  expect_error(field_data(1:4, t = 1:3), "`y` has 4 values, which do not split into blocks of 3")
})

test_that("field_data refuses empty, logical, factor and duplicated-name input", {
  expect_error(field_data(matrix(numeric(0), 0, 3)), "`y` must have at least 1 row",
               class = "griddy_error_input")
  expect_error(field_data(matrix(numeric(0), 2, 0)), "`y` must have at least 1 column")
  expect_error(field_data(c(TRUE, FALSE)), "`y` must be a numeric vector; received logical")
  expect_error(field_data(factor(1:3)), "received factor")
  expect_error(field_data(data.frame(a = c("1", "2"))), "column\\(s\\) a are character")
  x <- data.frame(h = 1:2, h = 3:4, check.names = FALSE)
  expect_error(field_data(matrix(1:4, 2), x = x), "`x` has duplicated column names: h")
  expect_error(field_data(matrix(1:4, 2), x = data.frame(h = c(1, NA))), "`x` must hold finite")
  expect_error(field_data(1:3, t = c(1, NA, 3)), "`t` must hold finite")
})

test_that("field_data reads a one-dimensional array as a vector", {
  y <- array(1:6)
  expect_identical(field_data(y, t = 1:3)$y, matrix(as.double(1:6), 2, byrow = TRUE))
})

test_that("integer64 measurements and settings are read as numbers", {
  skip_if_not_installed("bit64")
  f <- field_data(bit64::as.integer64(c(1, 2, 3, 2^40)), x = data.frame(h = bit64::as.integer64(c(5, 2^33))))
  expect_identical(f$y, rbind(c(1, 2), c(3, 2^40)))
  expect_identical(f$x$h, c(5, 2^33))
  f2 <- field_data(data.frame(a = bit64::as.integer64(c(1, 2^31))))
  expect_identical(f2$y, matrix(c(1, 2^31), 2))
})

test_that("field_data keeps missing cells and field_vector places them in the library's order", {
  lib <- sim_library(data.frame(k = 1:2), matrix(1:12, 2),
                     x = data.frame(h = c(10, 20, 30)), t = c(0, 1))
  f <- field_data(rbind(c(5, NA), c(1, 2)), x = data.frame(h = c(30, 10)), t = c(0, 1))
  expect_output(print(f), "3 measurement\\(s\\).*1 missing")
  # the library's setting 20 has no measurement: an all-NA block
  expect_identical(field_vector(lib, f), c(1, 2, NA, NA, 5, NA))
  # a field with only some of the library's t
  f2 <- field_data(matrix(c(7, 8, 9), 3), x = data.frame(h = c(10, 20, 30)), t = 1)
  expect_identical(field_vector(lib, f2), c(NA, 7, NA, 8, NA, 9))
})

test_that("long format gives the wide matrix with NA where not measured", {
  long <- data.frame(h = c(20, 10, 10), t = c(1, 0, 1), y = c(3, 1, 2))
  f <- field_data(long)
  expect_identical(f$x, data.frame(h = c(20, 10)))
  expect_identical(f$t, c(0, 1))
  expect_identical(f$y, rbind(c(NA, 3), c(1, 2)))
  lib <- sim_library(data.frame(k = 1:2), matrix(1:12, 2),
                     x = data.frame(h = c(10, 20, 30)), t = c(0, 1))
  expect_identical(field_vector(lib, f), c(1, 2, NA, 3, NA, NA))
  # the x settings and coordinates may be given, sd as a column
  f2 <- field_data(cbind(long, sd = c(1, 2, 3)), x = data.frame(h = c(10, 20)), t = c(0, 1))
  expect_identical(f2$sd, rbind(c(2, 3), c(NA, 1)))
  # t not in the library: a clear error
  f3 <- field_data(data.frame(h = 10, t = 0.5, y = 1))
  expect_error(field_vector(lib, f3), "0.5 \\(position\\(s\\) 1\\) are not among the library's",
               class = "griddy_error_input")
  expect_error(field_data(long, t = 0), "Row\\(s\\) 1, 3 of `y`")
})

test_that("sd takes the shape of y, one value per t or one per x setting", {
  y <- matrix(c(1, NA, 3, 4, 5, 6), 2)
  expect_identical(field_data(y, sd = c(1, 2, 3))$sd, rbind(c(1, 2, 3), c(1, 2, 3)))
  expect_identical(field_data(y, sd = c(1, 2))$sd, cbind(c(1, 2), c(1, 2), c(1, 2)))
  expect_identical(field_data(y, sd = 2 * y)$sd, 2 * y)
  expect_error(field_data(matrix(1:4, 2), sd = 1:2), "same number here", class = "griddy_error_shape")
  expect_error(field_data(y, sd = 1:4), "per measurement \\(6\\)", class = "griddy_error_shape")
  expect_error(field_data(y, sd = c(1, -1, 1)), "positive number wherever `y` is measured")
  expect_error(field_data(y, sd = matrix(1, 3, 2)), "shape of `y`", class = "griddy_error_shape")
})

test_that("replicated experiments: rows of y at a repeated x setting, kept as given", {
  x <- data.frame(h = c(10, 20, 10, 10))
  y <- rbind(c(1, 2), c(3, 4), c(1.2, NA), c(0.8, 2.4))
  f <- field_data(y, x = x, t = c(0, 1))
  expect_identical(f$y, y)
  expect_identical(f$x, x)
  expect_output(print(f), "7 measurement\\(s\\) at 2 x setting\\(s\\), 1 replicated \\(4 experiments\\)")
  lib <- sim_library(data.frame(k = 1:2), matrix(1:12, 2),
                     x = data.frame(h = c(10, 20, 30)), t = c(0, 1))
  # the cells: means, relative sd of the means, pure error
  lay <- field_layout(lib, f)
  expect_equal(lay$y, c(1, 2.2, 3, 4, NA, NA))
  expect_identical(lay$n_rep, c(3L, 2L, 1L, 1L, 0L, 0L))
  expect_equal(lay$sd_mean, c(1 / sqrt(3), 1 / sqrt(2), 1, 1, NA, NA))
  expect_null(lay$sd)
  expect_equal(lay$pure_ss, c(0.08, 0.08, 0, 0, 0, 0))
  # sd weights the mean; one measurement's sd is kept for predict()
  sd <- rbind(c(1, 1), c(1, 1), c(2, NA), c(2, 1))
  lay_sd <- field_layout(lib, field_data(y, x = x, t = c(0, 1), sd = sd))
  w <- c(1, 1 / 4, 1 / 4)
  expect_equal(lay_sd$y[1], sum(w * c(1, 1.2, 0.8)) / sum(w))
  expect_equal(lay_sd$sd_mean[1], 1 / sqrt(1.5))
  expect_equal(lay_sd$sd[1:4], c(sqrt(3 / 1.5), 1, 1, 1))
  expect_equal(lay_sd$pure_ss[1], sum(w * (c(1, 1.2, 0.8) - lay_sd$y[1])^2))
  # methods that take one measurement per cell refuse replicates
  expect_error(field_vector(lib, f), "replicated measurements \\(7 at 4 cells\\)",
               class = "griddy_error_unsupported")
})

test_that("long format: several values of one (x, t) cell are replicates", {
  long <- data.frame(h = c(20, 10, 10, 10, 10), t = c(1, 0, 1, 1, 0), y = c(3, 1, 2, 4, 5),
                     sd = c(1, 1, 2, 2, 1))
  f <- field_data(long)
  # the j-th value of a cell goes to the j-th row of its setting
  expect_identical(f$x, data.frame(h = c(20, 10, 10)))
  expect_identical(f$y, rbind(c(NA, 3), c(1, 2), c(5, 4)))
  expect_identical(f$sd, rbind(c(NA, 1), c(1, 2), c(1, 2)))
  expect_output(print(f), "5 measurement\\(s\\) at 2 x setting\\(s\\), 1 replicated")
  lib <- sim_library(data.frame(k = 1:2), matrix(1:12, 2),
                     x = data.frame(h = c(10, 20, 30)), t = c(0, 1))
  expect_equal(field_layout(lib, f)$y, c(3, 3, NA, 3, NA, NA))
  # the same as the wide form
  wide <- field_data(f$y, x = f$x, t = f$t, sd = f$sd)
  expect_equal(field_layout(lib, f), field_layout(lib, wide))
  # without x columns: every row at the library's single setting
  one <- field_data(data.frame(t = c(0, 1, 0), y = c(1, 2, 3)))
  expect_true(one$one_setting)
  expect_identical(one$y, rbind(c(1, 2), c(3, NA)))
  lib1 <- sim_library(data.frame(k = 1:2), matrix(1:4, 2), t = c(0, 1))
  expect_equal(field_layout(lib1, one)$y, c(2, 2))
  expect_error(field_layout(lib, one), "replicated measurements at one setting and no x columns",
               class = "griddy_error")
})

test_that("replicated input that does not fit together is refused", {
  x <- data.frame(h = c(10, 10))
  expect_error(field_data(matrix(1:6, 3), x = x), "`x` has 2 rows but `y` has 3")
  expect_error(field_data(matrix(1:6, 2), x = x, sd = c(1, -1)), "positive number wherever")
  # a long-format `x` lists settings: it must not repeat them
  long <- data.frame(h = c(10, 10), t = c(0, 0), y = c(1, 2))
  expect_error(field_data(long, x = x), "duplicated settings at row\\(s\\) 2")
  # the library must have the replicated settings
  lib <- sim_library(data.frame(k = 1:2), matrix(1:4, 2), x = data.frame(h = c(20, 30)))
  expect_error(calibrate(lib, field_data(c(1, 2), x = x), n_iter = 10, burn_in = 1),
               "x setting\\(s\\) at row\\(s\\) 1, 2 that the library does not have")
})

test_that("a wide y without x and t must have the library's shape, not only its size (issue 22)", {
  # 3 settings x 2 outputs: t(Y) has the right number of values in the wrong
  # order, and was read silently as if it were Y
  lib <- sim_library(data.frame(k = 1:2), matrix(1:12, 2),
                     x = data.frame(h = c(10, 20, 30)), t = c(0, 1))
  Y <- rbind(c(1, 2), c(3, 4), c(5, 6))
  expect_identical(field_vector(lib, field_data(Y)), c(1, 2, 3, 4, 5, 6))
  err <- expect_error(field_vector(lib, field_data(t(Y))), class = "griddy_error_shape")
  expect_match(conditionMessage(err), "2 x 3.*3 x settings x 2 outputs.*transposed")
  expect_error(field_vector(lib, field_data(matrix(1:6, 6))), class = "griddy_error_shape")
  # a vector (a one-row y) is in the library's order, as documented
  expect_identical(field_vector(lib, field_data(1:6)), as.double(1:6))
})

test_that("a long table whose value column is not `y` is refused, not read as wide (issue 22)", {
  long <- data.frame(h = c(10, 10, 20), t = c(0, 1, 1), value = c(1.1, 0.7, 0.4))
  err <- expect_error(field_data(long), class = "griddy_error_input")
  expect_match(conditionMessage(err), "column `t`.*no column `y`.*value")
  # a table with `y` but no `t` is refused too (its x columns would be read
  # as measurements)
  expect_error(field_data(data.frame(h = c(10, 20), y = c(1, 2))), "column `y` but no column `t`",
               class = "griddy_error_input")
  # columns named like x's columns are settings, not measurements
  expect_error(field_data(data.frame(h = c(10, 20), a = c(1, 2)), x = data.frame(h = c(10, 20))),
               "column\\(s\\) h of `y` are also columns of `x`", class = "griddy_error_input")
  # a wide data.frame of measurements still works
  expect_identical(field_data(data.frame(a = c(1, 3), b = c(2, 4)))$y, rbind(c(1, 2), c(3, 4)))
})

test_that("a long table's column spelled like `sd` is not read as an x setting (issue 22)", {
  long <- data.frame(h = c(10, 20), t = c(0, 0), y = c(1, 2), SD = c(0.1, 0.2))
  expect_error(field_data(long), "`SD`, which would be read as x settings",
               class = "griddy_error_input")
})

test_that("print.griddy_field() shows the measurements, their layout and range", {
  expect_snapshot(print(toy_xt(n_per_dim = 4)$field))
  expect_snapshot(print(toy_missing()$field))
  expect_snapshot(print(toy_replicates()$field))
})

test_that("field_cells() is the one mapping of field entries to library cells (issue 32)", {
  lib <- sim_library(data.frame(k = 1:2), matrix(1:12, 2),
                     x = data.frame(h = c(10, 20, 30)), t = c(0, 1))
  y <- rbind(c(1, 2), c(3, NA), c(1.2, 1.9))
  f <- field_data(y, x = data.frame(h = c(20, 10, 20) * (1 + 1e-13)), t = c(0, 1) + 1e-14)
  cells <- field_cells(lib, f)
  # y[k, j] at setting h (library row 2, 1, 2), coordinate t (column 1, 2):
  # cell (row - 1) * 2 + column
  expect_identical(cells$cell, c(3L, 1L, 3L, 4L, 2L, 4L))
  expect_identical(cells$value, as.vector(y))
  expect_null(cells$sd)
  # field_layout() summarises exactly these cells
  lay <- field_layout(lib, f)
  expect_identical(lay$n_rep, tabulate(cells$cell[!is.na(cells$value)], 6))
  expect_equal(lay$y, c(3, NA, mean(c(1, 1.2)), mean(c(2, 1.9)), NA, NA))
  # a vector in the library's order, and a matrix of its shape
  expect_identical(field_cells(lib, field_data(1:6))$cell, 1:6)
  expect_identical(field_cells(lib, field_data(matrix(1:6, 3, byrow = TRUE)))$value, as.numeric(1:6))
  expect_error(field_cells(lib, field_data(c(NA, NA), x = data.frame(h = 10), t = c(0, 1))),
               "no measurement")
  expect_error(field_cells(lib, list(y = 1)), "must be a griddy_field")
})
