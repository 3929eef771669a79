test_that("match_rows() is match() over rows: first hit, NA where none", {
  table <- data.frame(a = c(1, 2, 3, 2), b = c(0, 5, 6, 5))
  x <- data.frame(a = c(2, 3, 9, 1), b = c(5, 6, 0, 1))
  expect_identical(match_rows(x, table), c(2L, 3L, NA, NA))
  expect_identical(match_rows(as.matrix(x), as.list(table)), c(2L, 3L, NA, NA))
  expect_identical(match_rows(x[0, ], table), integer(0))
  expect_identical(match_rows(x, table[0, ]), rep(NA_integer_, 4))
  expect_identical(match_rows(data.frame(a = c(NA, 1)), data.frame(a = c(1, NA))), c(2L, 1L))
})

test_that("exact row matches are those of the values' bits as text (-0 apart, NA and NaN apart)", {
  bits_key <- function(cols) do.call(paste, c(lapply(cols, function(v) sprintf("%a", v)), sep = "|"))
  set.seed(4)
  pool <- c(0, -0, 1, -1, 0.1, NA, NaN, Inf, 1e-300)
  for (k in 1:3) {
    x <- replicate(k, sample(pool, 400, TRUE), simplify = FALSE)
    table <- replicate(k, sample(pool, 300, TRUE), simplify = FALSE)
    expect_identical(exact_row_match(x, table), match(bits_key(x), bits_key(table)))
    expect_identical(exact_row_match(x, x), match(bits_key(x), bits_key(x)))
  }
  expect_identical(exact_row_match(list(numeric(0)), list(1)), integer(0))
  expect_identical(exact_row_match(list(c(1, 2)), list(numeric(0))), c(NA_integer_, NA_integer_))
})

test_that("a design written with write.csv() or fwrite() and read back matches itself", {
  design <- design_lhs(50, k = c(1, 4), c = c(0, 1e-6), seed = 1)
  file <- withr::local_tempfile(fileext = ".csv")
  utils::write.csv(design, file, row.names = FALSE)
  back <- utils::read.csv(file)
  expect_false(all(back$k == design$k))  # 15 digits: not the same bits
  expect_identical(match_rows(back[50:1, ], design), 50:1)
  data.table::fwrite(design, file)
  expect_identical(match_rows(data.table::fread(file), design), 1:50)
})

test_that("the tolerance is relative to each column's scale, and distinct runs stay apart", {
  table <- data.frame(k = c(1000, 2000), c = c(1e-9, 2e-9))
  # within 1e-8 of each column's largest value: the same run
  expect_identical(match_rows(data.frame(k = 2000 + 1e-6, c = 2e-9 + 1e-18), table), 2L)
  # apart by 1e-7 of the scale in one column: another run
  expect_identical(match_rows(data.frame(k = 2000, c = 2e-9 + 2e-16), table), NA_integer_)
  expect_identical(match_rows(data.frame(k = 2000 + 2e-4, c = 2e-9), table), NA_integer_)
  expect_identical(match_rows(data.frame(k = 2000 + 1e-6, c = 2e-9), table, tolerance = 0),
                   NA_integer_)
  # a grid whose lead column repeats: every row found
  grid <- design_grid(a = 1:20 / 3, b = 1:30 / 7)
  expect_identical(match_rows(grid * (1 + 1e-12), grid), seq_len(nrow(grid)))
})

test_that("row_groups() numbers equal rows alike, near rows included", {
  x <- data.frame(a = c(1, 2, 1 + 1e-12, 3, 2), b = c(5, 6, 5, 7, 6 * (1 + 1e-11)))
  expect_identical(row_groups(x), c(1L, 2L, 1L, 3L, 2L))
  expect_identical(row_groups(x, tolerance = 0), c(1L, 2L, 3L, 4L, 5L))
  # a design written to CSV and read back groups as it did
  path <- withr::local_tempfile(fileext = ".csv")
  d <- data.frame(k = c(0.1, 0.3, 0.1, 0.7) / 3, c = c(1, 2, 1, 2) / 7)
  utils::write.csv(d, path, row.names = FALSE)
  back <- utils::read.csv(path)
  expect_false(identical(back, d))  # not the same bits
  expect_identical(row_groups(rbind(d, back)), c(1L, 2L, 1L, 3L, 1L, 2L, 1L, 3L))
})

test_that("row_groups() of many rows with few values pairs distinct rows only", {
  # each row's group: its first near row over all rows (the definition)
  by_pairs <- function(x) {
    x <- lapply(as.list(x), as.double)
    scale <- vapply(x, function(v) max(abs(v)) * match_tolerance, 0)
    first <- vapply(seq_along(x[[1]]), function(i) {
      which(Reduce(`&`, Map(function(v, s) abs(v - v[i]) <= s, x, scale)))[1]
    }, 1L)
    match(first, unique(first))
  }
  set.seed(4)
  x <- data.frame(s = sample(c(0, 0.1, 0.2), 300, TRUE), k = sample(1:4, 300, TRUE))
  x$s[c(5, 50)] <- x$s[c(5, 50)] * (1 + 1e-12)   # near ties too
  expect_identical(row_groups(x), by_pairs(x))
  # a candidate's strength levels over 10^5 runs: ~n^2 / 4 pairs before (11 GB)
  s <- rep(c(0, 0.1, 0.2, 0.3), length.out = 1e5)
  expect_identical(row_groups(cbind(s = s)), rep(1:4, length.out = 1e5))
})
