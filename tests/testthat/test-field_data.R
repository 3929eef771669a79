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
  expect_error(field_data(c(1, NA)), "found NA")
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
  expect_error(field_vector(lib, field_data(matrix(1:6, 3), t = c(0, 2))), "does not match the library's t")
  expect_error(field_vector(lib, field_data(matrix(1:6, 3), x = data.frame(v = 1:3))), "column\\(s\\) v but the library's x has h")
  expect_error(field_vector(lib, field_data(matrix(1:6, 3), x = data.frame(h = c(10, 20, 40)))),
               "no measurements at library x setting\\(s\\) 3")
  expect_error(field_vector(lib, field_data(matrix(1:8, 4), x = data.frame(h = c(10, 20, 30, 40)))),
               "x setting\\(s\\) at row\\(s\\) 4 that the library does not have")
  expect_error(field_vector(list(), field_data(1)), "`library` must be a sim_library")
  expect_error(field_vector(lib, 1:6), "`field` must be a griddy_field")
})
