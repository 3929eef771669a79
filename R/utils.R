# One rule for "the same run": rows of numbers matched by value.
#
# match_rows(x, table) is match() over rows: for each row of `x`, the first
# row of `table` with the same values, NA where none has. Values are the
# same when they differ by at most `tolerance` times their column's scale,
# the largest absolute finite value of the column in `x` and `table`
# together (a column of zeros matches exactly). The default, 1e-8 relative,
# takes a design written with write.csv() or data.table::fwrite() (15 or
# more significant digits) and read back as the design it was, while runs a
# design tells apart (their values differ in the 8th significant digit of
# the column's scale or before) stay apart. NA matches NA only.
#
# `x` and `table` are data.frames, matrices or lists of numeric columns, the
# same columns in the same order (names are not looked at).
match_rows <- function(x, table, tolerance = match_tolerance) {
  x <- lapply(as.list(as.data.frame(x)), as.double)
  table <- lapply(as.list(as.data.frame(table)), as.double)
  stopifnot(length(x) == length(table), length(x) > 0L, tolerance >= 0)
  n <- length(x[[1]])
  out <- exact_row_match(x, table)
  miss <- which(is.na(out))
  if (length(miss) == 0L || length(table[[1]]) == 0L || tolerance == 0) return(out)
  scale <- mapply(function(a, b) max(0, abs(c(a, b)), na.rm = TRUE) * tolerance, x, table)
  out[miss] <- near_row_match(lapply(x, `[`, miss), table, scale)
  out
}

match_tolerance <- 1e-8

# The group of each row of `x`: rows equal under match_rows() share one,
# numbered 1, 2, ... in order of first appearance.
# (match_rows(x, x) would find each row itself, so near rows are looked
# for among all rows: each row's first near row.)
row_groups <- function(x, tolerance = match_tolerance) {
  x <- lapply(as.list(as.data.frame(x)), as.double)
  first <- exact_row_match(x, x)
  if (tolerance > 0 && length(x[[1]]) > 1L) {
    scale <- vapply(x, function(v) max(0, abs(v), na.rm = TRUE) * tolerance, 0)
    # near rows among the distinct rows only: a column of few values (a
    # candidate's strength levels over 10^5 runs) would otherwise pair every
    # row with every equal one, n^2 / levels pairs
    reps <- which(first == seq_along(first))
    x_reps <- lapply(x, `[`, reps)
    near <- near_row_match(x_reps, x_reps, scale)
    near_first <- ifelse(is.na(near), reps, pmin(reps[near], reps))
    first <- near_first[match(first, reps)]
  }
  match(first, unique(first))
}

# Rows with the very same bits (NA equal to NA): the common case, by hashing.
# Each column's values are numbered by match() (which hashes doubles), -0
# apart from 0 as the bits have it, and the columns' numbers are combined
# pairwise into one number per row (below 4 n^2 for n rows in all, exact
# in a double); then a row's key is matched, not text
# (sprintf("%a") keys took a fifth of diagnose_gap() with two candidates of
# 10^5 runs, in check_zero_strength() and the strength levels).
exact_row_match <- function(x, table) {
  n <- length(x[[1]])
  if (n == 0L || length(table[[1]]) == 0L) return(rep(NA_integer_, n))
  key <- NULL
  for (k in seq_along(x)) {
    v <- c(x[[k]], table[[k]])
    # a value's number: where it first occurs (one hashing pass)
    id <- 2 * match(v, v) - (v == 0 & !is.na(v) & 1 / v < 0)
    key <- if (is.null(key)) id else {
      both <- key + (id - 1) * max(key)
      match(both, both)
    }
  }
  match(key[seq_len(n)], key[-seq_len(n)])
}

# Rows within `scale` (one width per column) of a row of `table`: the table
# sorted by its most varied column, the candidates of each row of x found in
# its window there, then every pair checked on all columns at once.
near_row_match <- function(x, table, scale) {
  lead <- which.max(vapply(table, function(v) length(unique(v)), 1L))
  key <- table[[lead]]
  o <- order(key, na.last = NA)
  sorted <- key[o]
  v <- x[[lead]]
  from <- findInterval(v - scale[lead], sorted, left.open = TRUE) + 1L
  to <- findInterval(v + scale[lead], sorted)
  count <- ifelse(is.na(v), 0L, pmax(0L, to - from + 1L))
  out <- rep(NA_integer_, length(v))
  if (sum(count) == 0L) return(out)
  row <- rep(seq_along(v), count)
  cand <- o[sequence(count[count > 0L], from[count > 0L])]
  ok <- rep(TRUE, length(row))
  for (j in seq_along(x)) {
    a <- x[[j]][row]
    b <- table[[j]][cand]
    near <- abs(a - b) <= scale[j] | (is.na(a) & is.na(b))
    ok <- ok & !is.na(near) & near
  }
  hit <- data.frame(row = row[ok], cand = cand[ok])
  hit <- hit[order(hit$row, hit$cand), , drop = FALSE]
  hit <- hit[!duplicated(hit$row), , drop = FALSE]
  out[hit$row] <- hit$cand
  out
}
