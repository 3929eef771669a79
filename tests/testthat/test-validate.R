test_that("as_numeric_matrix names non-numeric columns and non-finite cells", {
  expect_error(as_numeric_matrix(data.frame(a = 1:2, b = c("x", "y")), "theta"),
               "`theta` must be numeric; column\\(s\\) b are character")
  m <- matrix(c(1, NA, 3, Inf), 2, dimnames = list(NULL, c("p", "q")))
  expect_error(as_numeric_matrix(m, "y"), "found NA, Inf at \\[2, p\\], \\[2, q\\]")
  expect_error(as_numeric_matrix(list(1), "y"), "received list")
  expect_identical(dim(as_numeric_matrix(1:3, "v")), c(1L, 3L))
})

test_that("show_some shortens long lists", {
  expect_identical(show_some(1:3), "1, 2, 3")
  expect_identical(show_some(1:7, 2), "1, 2, ... (7 in all)")
})

test_that("scalar checks reject bad values with the argument's name", {
  expect_error(assert_count(2.5, "n_iter"), "`n_iter` must be a single whole number >= 1; received 2.5")
  expect_error(assert_count(0, "thin"), "`thin`")
  expect_identical(assert_count(0, "burn_in", min = 0L), 0L)
  expect_error(assert_flag(NA, "progress"), "`progress` must be TRUE or FALSE")
  expect_error(assert_rho_grid(c(0, 1), "rho_t"), "must lie in \\[0, 1\\).*received 1")
  expect_error(assert_rho_grid(c(0.5, 0.5), "rho_t"), "duplicated")
  expect_error(assert_numeric_vector("a", "t"), "`t` must be a numeric vector")
})

test_that("assert_prior checks shape and rate", {
  expect_error(assert_prior(list(shape = 1)), "`prior` must be a list with elements")
  expect_error(assert_prior(list(shape = 0, rate = 1)), "`prior\\$shape` must be a single positive")
  expect_error(assert_prior(list(shape = 1, rate = -1)), "`prior\\$rate` must be a single number >= 0")
  expect_identical(assert_prior(list(shape = 2L, rate = 0)), list(shape = 2, rate = 0))
})

test_that("assert_number checks length, finiteness and open or closed bounds", {
  expect_identical(assert_number(2L, "k", lower = 0), 2)
  expect_error(assert_number(c(1, 2), "k"), "`k` must be 1 finite number in \\[-Inf, Inf\\]; received 1, 2")
  expect_error(assert_number(0, "k", lower = 0, lower_open = TRUE), "\\(0, Inf\\]")
  expect_error(assert_number(1, "rho", lower = 0, upper = 1, upper_open = TRUE), "\\[0, 1\\); received 1")
  expect_identical(assert_number(c(1, 3), "h", len = NULL, lower = 0), c(1, 3))
  expect_error(assert_number(NA_real_, "h", len = NULL), "finite numbers")
  expect_error(assert_number("a", "h"), "received character")
})

test_that("assert_level names the argument it checks", {
  expect_identical(assert_level(0.95), 0.95)
  expect_error(assert_level(1), "`level` must be a single number in \\(0, 1\\); received 1")
  expect_error(assert_level(0, "fdr"), "`fdr` must be a single number in \\(0, 1\\)")
})
