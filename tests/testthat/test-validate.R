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

test_that("integer64 columns and vectors are read as their numbers, not their bits", {
  skip_if_not_installed("bit64")
  big <- bit64::as.integer64(c(1, 2^31, 3))
  m <- as_numeric_matrix(data.frame(a = big, b = 1:3), "theta")
  expect_identical(m[, "a"], c(1, 2^31, 3))
  expect_identical(m[, "b"], c(1, 2, 3))
  expect_identical(as_numeric_matrix(big, "y"), matrix(c(1, 2^31, 3), 1))
  expect_identical(assert_numeric_vector(big, "t"), c(1, 2^31, 3))
  expect_identical(assert_number(bit64::as.integer64(5), "k"), 5)
  expect_identical(assert_count(bit64::as.integer64(7), "n_iter"), 7L)
  expect_error(assert_numeric_vector(bit64::as.integer64(c(1, NA)), "t"),
               "`t` must hold finite numbers; found NA at \\[2\\]", class = "griddy_error_input")
})

test_that("integer64 without bit64 installed is refused, not misread", {
  fake <- structure(0, class = "integer64")
  expect_error(as_plain_numeric(fake, "design$k", bit64 = FALSE),
               "`design\\$k` is of class integer64 .* package 'bit64' is needed to read",
               class = "griddy_error_package")
  expect_identical(as_plain_numeric(1:2, "v", bit64 = FALSE), 1:2)
})

test_that("whole-number validators refuse values that do not fit an integer", {
  expect_error(assert_count(2^31, "n_iter"),
               "`n_iter` must be a single whole number >= 1 that fits an integer \\(at most 2147483647\\); received 2147483648",
               class = "griddy_error_input")
  expect_error(assert_count(1e300, "n_iter"), "fits an integer", class = "griddy_error_input")
  expect_error(assert_count(50, "thin", max = 10), "`thin` must be a single whole number in 1..10; received 50")
  expect_identical(assert_count(.Machine$integer.max, "n_iter"), .Machine$integer.max)
  expect_error(assert_count(NA, "n_iter"), "received NA")
  expect_error(assert_count(TRUE, "n_iter"), "received TRUE")
  expect_error(assert_count(integer(0), "n_iter"), "received nothing")
  expect_error(assert_count("3", "n_iter"), "received character")
  expect_identical(assert_whole(c(3, 1), "loc", lower = 1, upper = 27, len = NULL, distinct = TRUE),
                   c(3L, 1L))
  expect_error(assert_whole(c(3, 3), "loc", lower = 1, upper = 27, len = NULL, distinct = TRUE),
               "`loc` must be distinct whole numbers in 1..27; received 3, 3")
  expect_error(assert_whole(1:2, "n", len = 1L), "single whole number")
})

test_that("assert_choice takes one (or several) of the choices, the default vector meaning the first", {
  expect_identical(assert_choice(c("a", "b"), "model", c("a", "b"), vector_default = TRUE), "a")
  expect_error(assert_choice(c("a", "b"), "model", c("a", "b")), "`model` must be one of")
  expect_identical(assert_choice("b", "model", c("a", "b")), "b")
  expect_identical(assert_choice(c("b", "a"), "cond", c("a", "b"), several = TRUE), c("b", "a"))
  expect_error(assert_choice("c", "model", c("a", "b")),
               "`model` must be one of \"a\", \"b\"; received \"c\"", class = "griddy_error_input")
  expect_error(assert_choice(c("a", "a"), "cond", c("a", "b"), several = TRUE),
               "one or more distinct of")
  expect_error(assert_choice(NA_character_, "model", c("a", "b")), "received \"NA\"")
  expect_error(assert_choice(factor("a"), "model", c("a", "b")), "received factor a")
  expect_error(assert_choice(character(0), "model", c("a", "b")), "received nothing")
})

test_that("assert_seed takes NULL or one whole number", {
  expect_null(assert_seed(NULL))
  expect_identical(assert_seed(-5), -5L)
  expect_error(assert_seed("a"), "`seed` must be a single whole number")
  expect_error(assert_seed(1.5), "received 1.5")
})

test_that("assert_dots names the further arguments that the callee does not take", {
  expect_invisible(assert_dots(list(cell = 1), c("material", "cell"), "piston_model()"))
  expect_error(assert_dots(list(materal = 1), c("material", "cell"), "piston_model()"),
               "may be material, cell; received materal", class = "griddy_error_input")
  expect_error(assert_dots(list(1), c("material", "cell"), "piston_model()"), "must be named")
  expect_error(assert_dots(list(cell = 1, cell = 2), "cell", "piston_model()"), "more than once")
})

test_that("assert_range names the positions outside the range", {
  m <- matrix(c(1, -2, 3, 0), 2)
  expect_error(assert_range(m, "htc", lower = 0, lower_open = TRUE),
               "`htc` must lie in \\(0, Inf\\]; received -2, 0 at \\[2, 1\\], \\[2, 2\\]")
  expect_invisible(assert_range(1:3, "v", 1, 3))
})

test_that("as_numeric_matrix checks the number of columns and rows when asked", {
  expect_error(as_numeric_matrix(matrix(1, 2, 4), "htc", n_col = 3),
               "`htc` must have 3 column\\(s\\); received 2 x 4")
  expect_error(as_numeric_matrix(matrix(1, 0, 3), "htc", min_rows = 1), "at least 1 row")
  expect_error(as_numeric_matrix(data.frame(a = c(TRUE, FALSE)), "y"), "column\\(s\\) a are logical")
  expect_error(as_numeric_matrix(data.frame(a = factor(1:2)), "y"), "column\\(s\\) a are factor")
  expect_error(as_numeric_matrix(matrix(TRUE, 2, 2), "y"), "received matrix of type logical")
  expect_error(assert_number(numeric(0), "k"), "received nothing")
})

test_that("assert_choice takes numeric choices too", {
  expect_identical(assert_choice(0.5, "cell", c(0.25, 0.5, 1)), 0.5)
  expect_identical(assert_choice(1L, "cell", c(0.25, 0.5, 1)), 1)
  expect_error(assert_choice(2, "cell", c(0.25, 0.5, 1)),
               "`cell` must be one of 0.25, 0.5, 1; received 2", class = "griddy_error_input")
  expect_error(assert_choice("1", "cell", c(0.25, 0.5, 1)), "received character 1")
})

test_that("the package raises no condition with a raw stop() or warning()", {
  dir <- testthat::test_path("..", "..", "R")
  skip_if_not(dir.exists(dir), "package sources not available")
  code <- unlist(lapply(list.files(dir, "\\.R$", full.names = TRUE), function(f) {
    lines <- readLines(f, warn = FALSE)
    hit <- grep("(^|[^_.[:alnum:]])(stop|warning)\\(", sub("#.*$", "", lines))
    # griddy_warn() signals a classed condition built by warningCondition()
    hit <- hit[!grepl("(stop|warning)\\((error|warning)Condition\\(", lines[hit])]
    if (length(hit)) paste0(basename(f), ":", hit, ": ", trimws(lines[hit]))
  }))
  expect_identical(code, NULL)
})

test_that("outputs and field at scale 1e-300: underflow is named, not an exact reproduction (issue 22)", {
  ex <- griddy_example()
  lib <- ex$library
  scaled <- function(s) {
    list(library = sim_library(lib$theta, lib$y * s, x = lib$x, t = lib$t),
         field = field_data(ex$field$y * s, x = ex$field$x, t = ex$field$t))
  }
  tiny <- scaled(1e-300)
  for (prior in list(NULL, list(shape = 1e-9, rate = 0))) {
    err <- expect_error(calibrate(tiny$library, tiny$field, prior = prior, n_iter = 200,
                                  burn_in = 50, seed = 1), class = "griddy_error_scale")
    expect_match(conditionMessage(err), "scale 9.63e-300.*underflow.*multiply both by 1e\\+299")
    expect_no_match(conditionMessage(err), "exactly")
  }
  expect_error(posterior_exact(tiny$library, tiny$field), class = "griddy_error_scale")
  # tau then overflowed and reached the sampler or summary() as NaN
  expect_error(calibrate(scaled(1e-160)$library, scaled(1e-160)$field, update = "thesis",
                         prior = list(shape = 1e-9, rate = 0), n_iter = 200, burn_in = 50,
                         seed = 1), class = "griddy_error_scale")
  # a small scale that doubles still hold is calibrated as usual
  small <- scaled(1e-150)
  fit <- suppressWarnings(calibrate(small$library, small$field, n_iter = 200, burn_in = 50,
                                    prior = list(shape = 1e-9, rate = 0), seed = 1))
  ref <- suppressWarnings(calibrate(lib, ex$field, n_iter = 200, burn_in = 50,
                                    prior = list(shape = 1e-9, rate = 0), seed = 1))
  expect_identical(fit$draws$k, ref$draws$k)
})
