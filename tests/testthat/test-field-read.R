# Two theta values run at three heights, design rows shuffled; run (h, k)
# outputs h * 100 + k * 10 + 1:2 so every block can be recognised.
thesis_inputs <- function() {
  design <- data.frame(h = c(2, 1, 3, 3, 1, 2), k = c(5, 5, 5, 7, 7, 7))
  simobs <- t(vapply(seq_len(nrow(design)), function(r) {
    design$h[r] * 100 + design$k[r] * 10 + 1:2
  }, numeric(2)))
  expobs <- data.frame(h = c(3, 1, 2), m1 = c(31, 11, 21), m2 = c(32, 12, 22))
  list(design = design, simobs = as.data.frame(simobs), expobs = expobs)
}

test_that("runs sharing theta become one library row, blocks in expobs order", {
  d <- thesis_inputs()
  out <- read_calibration_inputs(d$design, d$simobs, d$expobs, n_x = 1)
  lib <- out$library
  expect_identical(lib$theta$k, c(5, 7))
  expect_identical(lib$x$h, c(3, 1, 2))
  expect_identical(lib$y[1, ], c(351, 352, 151, 152, 251, 252))
  expect_identical(lib$y[2, ], c(371, 372, 171, 172, 271, 272))
  expect_identical(field_vector(lib, out$field), c(31, 32, 11, 12, 21, 22))
})

test_that("files and the transposed simobs layout are read too", {
  d <- thesis_inputs()
  dir <- tempfile("griddy-inputs")
  dir.create(dir)
  on.exit(unlink(dir, recursive = TRUE))
  paths <- file.path(dir, c("design.csv", "simobs.txt", "expobs.csv"))
  data.table::fwrite(d$design, paths[1])
  data.table::fwrite(as.data.frame(t(d$simobs)), paths[2], sep = " ")
  data.table::fwrite(d$expobs, paths[3])
  out <- read_calibration_inputs(paths[1], paths[2], paths[3], n_x = 1, t = c(0, 0.5))
  expect_identical(out$library$y[2, ], c(371, 372, 171, 172, 271, 272))
  expect_identical(out$library$t, c(0, 0.5))
})

test_that("inputs without x columns give a single setting", {
  design <- data.frame(k = 1:3)
  out <- read_calibration_inputs(design, data.frame(a = 1:3, b = 4:6),
                                 data.frame(m1 = 2, m2 = 5), n_x = 0)
  expect_null(out$library$x)
  expect_identical(out$library$y[3, ], c(3, 6))
})

test_that("bad thesis-format inputs get clear errors", {
  d <- thesis_inputs()
  dup <- rbind(d$design, d$design[2, ])
  expect_error(read_calibration_inputs(dup, rbind(d$simobs, d$simobs[2, ]), d$expobs, 1),
               "duplicated \\(x, theta\\) rows: row\\(s\\) 7 repeat row\\(s\\) 2")
  expect_error(read_calibration_inputs(d$design, d$simobs[1:5, ], d$expobs, 1),
               "one row \\(or one column\\) per `design` row \\(6\\); it is 5 x 2")
  expect_error(read_calibration_inputs(d$design, d$simobs, d$expobs[, 1:2], 1),
               "`expobs` must have the 1 x column\\(s\\) then the 2 measurements")
  expect_error(read_calibration_inputs(d$design, d$simobs, d$expobs, 2),
               "at least one theta column")
  bad <- d$expobs
  bad$m1[2] <- NA
  # a missing measurement reaches field_data() as NA (which decides on it)
  got <- tryCatch(read_calibration_inputs(d$design, d$simobs, bad, 1)$field$y,
                  griddy_error = function(e) conditionMessage(e))
  expect_true(is.character(got) && grepl("NA", got) || is.na(got[2, 1]))
  bad <- d$expobs
  bad$h[2] <- NA
  expect_error(read_calibration_inputs(d$design, d$simobs, bad, 1), "x columns")
  bad <- d$design
  bad$k <- as.character(bad$k)
  expect_error(read_calibration_inputs(bad, d$simobs, d$expobs, 1), "`design` must be numeric; column\\(s\\) k")
  expect_error(read_calibration_inputs("no-such-file.csv", d$simobs, d$expobs, 1), "`design` file not found")
  expect_error(read_calibration_inputs(d$design, d$simobs, d$expobs, -1), "`n_x`")
  expect_error(read_calibration_inputs(1:3, d$simobs, d$expobs, 1), "must be a file path, a data.frame or a matrix")
  one <- d$design$k == 5
  expect_error(read_calibration_inputs(d$design[one, ], d$simobs[one, ], d$expobs, 1),
               "`theta` holds 1 run: a library needs at least 2 runs")
})

test_that("runs at settings expobs lacks are dropped with a message", {
  d <- thesis_inputs()
  expect_message(out <- read_calibration_inputs(d$design, d$simobs, d$expobs[1:2, ], 1),
                 "2 `design` run\\(s\\) at x settings that `expobs` lacks were dropped \\(row\\(s\\) 1, 6\\)")
  expect_identical(out$library$y[1, ], c(351, 352, 151, 152))
})

# Write a data.frame as a csv file without a header line.
write_headerless <- function(d, path) {
  data.table::fwrite(as.data.frame(d), path, col.names = FALSE)
  path
}

test_that("a square simobs is refused in auto layout and read as told by simobs_layout", {
  # no x columns, three runs, three outputs: simobs is 3 x 3
  design <- data.frame(k = c(1, 2, 3))
  by_run <- rbind(c(11, 12, 13), c(21, 22, 23), c(31, 32, 33))   # row r = run r
  expobs <- data.frame(m1 = 1, m2 = 2, m3 = 3)
  expect_error(read_calibration_inputs(design, by_run, expobs, n_x = 0),
               "`simobs` is 3 x 3.*ambiguous.*simobs_layout = \"runs_in_rows\".*\"runs_in_columns\"",
               class = "griddy_error_input")
  rows <- read_calibration_inputs(design, by_run, expobs, n_x = 0, simobs_layout = "runs_in_rows")
  expect_identical(rows$library$y[2, ], c(21, 22, 23))
  cols <- read_calibration_inputs(design, t(by_run), expobs, n_x = 0,
                                  simobs_layout = "runs_in_columns")
  expect_identical(cols$library$y[2, ], c(21, 22, 23))
  expect_error(read_calibration_inputs(design, by_run[, 1:2], expobs[1:2], n_x = 0,
                                       simobs_layout = "runs_in_columns"),
               "one column per `design` row \\(3\\) with simobs_layout = \"runs_in_columns\"; it is 3 x 2")
  expect_error(read_calibration_inputs(design, by_run, expobs, n_x = 0, simobs_layout = "rows"),
               "`simobs_layout` must be one of \"auto\", \"runs_in_rows\", \"runs_in_columns\"")
})

test_that("headerless design, simobs and expobs files keep their first row", {
  d <- thesis_inputs()
  dir <- withr::local_tempdir()
  paths <- c(write_headerless(d$design, file.path(dir, "design.csv")),
             write_headerless(d$simobs, file.path(dir, "simobs.csv")),
             write_headerless(d$expobs, file.path(dir, "expobs.csv")))
  out <- read_calibration_inputs(paths[1], paths[2], paths[3], n_x = 1)
  ref <- read_calibration_inputs(d$design, d$simobs, d$expobs, n_x = 1)
  expect_identical(out$library$y, ref$library$y)
  expect_identical(unname(out$library$theta), unname(ref$library$theta))
  expect_identical(out$field$y, ref$field$y)
  # a whitespace-separated, headerless simobs with one column per run
  write.table(t(d$simobs), file.path(dir, "simobs.txt"), row.names = FALSE, col.names = FALSE)
  out2 <- read_calibration_inputs(paths[1], file.path(dir, "simobs.txt"), paths[3], n_x = 1)
  expect_identical(out2$library$y, ref$library$y)
  # a one-line headerless expobs (a single x setting) is one measurement row, not a header
  design <- data.frame(k = c(1, 2, 3))
  write_headerless(data.frame(a = 5, b = 6), file.path(dir, "exp1.csv"))
  one <- read_calibration_inputs(design, data.frame(a = 1:3, b = 4:6),
                                 file.path(dir, "exp1.csv"), n_x = 0)
  expect_identical(one$field$y, matrix(c(5, 6), 1))
})

test_that("files with a header line still use it for the names", {
  d <- thesis_inputs()
  dir <- withr::local_tempdir()
  data.table::fwrite(d$design, file.path(dir, "design.csv"))
  data.table::fwrite(d$simobs, file.path(dir, "simobs.csv"))
  data.table::fwrite(d$expobs, file.path(dir, "expobs.csv"))
  out <- read_calibration_inputs(file.path(dir, "design.csv"), file.path(dir, "simobs.csv"),
                                 file.path(dir, "expobs.csv"), n_x = 1)
  expect_named(out$library$theta, "k")
  expect_named(out$library$x, "h")
  expect_identical(nrow(out$library$theta), 2L)
})

test_that("integer64 columns (fread's whole numbers >= 2^31) are read as numbers", {
  skip_if_not_installed("bit64")
  d <- thesis_inputs()
  d$design$k <- d$design$k * 1e9                      # 5e9 and 7e9 do not fit an integer
  dir <- withr::local_tempdir()
  data.table::fwrite(d$design, file.path(dir, "design.csv"))
  out <- read_calibration_inputs(file.path(dir, "design.csv"), d$simobs, d$expobs, n_x = 1)
  expect_identical(out$library$theta$k, c(5e9, 7e9))
  big <- d$design
  big$k <- bit64::as.integer64(big$k)
  big_sim <- d$simobs
  big_sim$V1 <- bit64::as.integer64(big_sim$V1)
  out2 <- read_calibration_inputs(big, big_sim, d$expobs, n_x = 1)
  expect_identical(out2$library$theta$k, c(5e9, 7e9))
  expect_identical(out2$library$y, out$library$y)
  expect_true(is.double(out2$library$theta$k))
})

test_that("design column names must be present and distinct", {
  d <- thesis_inputs()
  dup <- d$design
  names(dup) <- c("k", "k")
  expect_error(read_calibration_inputs(dup, d$simobs, d$expobs, n_x = 1),
               "`design` has duplicated column names: k", class = "griddy_error_input")
  unnamed <- d$design
  names(unnamed) <- c("h", "")
  expect_error(read_calibration_inputs(unnamed, d$simobs, d$expobs, n_x = 1),
               "`design` must have a name for every column; column\\(s\\) 2")
})

test_that("scalar arguments are checked before any file is read", {
  expect_error(read_calibration_inputs("no-such-file.csv", "x", "y", n_x = 2^31),
               "`n_x` must be a single whole number >= 0 that fits an integer")
  expect_error(read_calibration_inputs("no-such-file.csv", "x", "y", n_x = TRUE), "`n_x`")
  expect_error(read_calibration_inputs(c("a.csv", "b.csv"), "x", "y", n_x = 1),
               "`design` must be a file path, a data.frame or a matrix; received character")
})

test_that("a numeric header line is read as data, and the error says so", {
  d <- thesis_inputs()
  dir <- withr::local_tempdir()
  sim <- d$simobs
  names(sim) <- c("0.5", "1")                         # output times as a header
  data.table::fwrite(sim, file.path(dir, "simobs.csv"))
  expect_error(read_calibration_inputs(d$design, file.path(dir, "simobs.csv"), d$expobs, n_x = 1),
               "it is 7 x 2\\. \\(The first line of the file holds numbers only, so it was read as data",
               class = "griddy_error_input")
})

test_that("replicated experiments in expobs are kept as replicates (they were refused)", {
  theta <- expand.grid(k = 1:3, c = c(0.5, 1))
  x <- c(10, 20)
  design <- merge(data.frame(h = x), theta, by = NULL)
  simobs <- cbind(design$k * design$h, design$c * design$h)
  expobs <- data.frame(h = c(10, 10, 20, 20, 20), a = c(21, 19, 41, 40, 39),
                       b = c(5, 6, 10, NA, 11))
  inputs <- read_calibration_inputs(design, simobs, expobs, n_x = 1)
  expect_s3_class(inputs$library, "sim_library")
  expect_equal(inputs$library$x, data.frame(h = c(10, 20)))
  expect_equal(sum(!is.na(inputs$field$y)), 9L)
  pr <- local_problem(inputs$library, inputs$field)
  expect_identical(pr$n_obs, 9L)
  # n_x = 0: every row an experiment at the one setting
  one <- read_calibration_inputs(theta, cbind(theta$k, theta$c),
                                 data.frame(a = c(2, 2.2), b = c(1, 0.9)), n_x = 0)
  pr1 <- local_problem(one$library, one$field)
  expect_identical(pr1$n_obs, 4L)
  expect_equal(pr1$y_field, c(2.1, 0.95))
})

test_that("comment lines in input files are skipped, never read as a header or a row (issue 22)", {
  d <- thesis_inputs()
  dir <- withr::local_tempdir()
  with_comments <- function(df, path, header = TRUE) {
    body <- utils::capture.output(utils::write.csv(df, stdout(), row.names = FALSE))
    if (!header) body <- body[-1]
    writeLines(c("# written by the simulator, 2026-11-25", "  # units: SI", body[1],
                 "# a comment between rows", body[-1]), path)
    path
  }
  ref <- read_calibration_inputs(d$design, d$simobs, d$expobs, n_x = 1)
  out <- read_calibration_inputs(with_comments(d$design, file.path(dir, "design.csv")),
                                 with_comments(d$simobs, file.path(dir, "simobs.csv"), FALSE),
                                 with_comments(d$expobs, file.path(dir, "expobs.csv")),
                                 n_x = 1)
  expect_identical(out$library$y, ref$library$y)
  expect_identical(out$library$theta, ref$library$theta)
  expect_identical(out$field$y, ref$field$y)
  expect_identical(names(out$library$x), "h")
  # a headerless expobs whose first line is a comment keeps its first row
  with_comments(d$expobs, file.path(dir, "expobs-nohead.csv"), header = FALSE)
  out2 <- read_calibration_inputs(d$design, d$simobs, file.path(dir, "expobs-nohead.csv"),
                                  n_x = 1)
  expect_identical(out2$field$y, ref$field$y)
})

test_that("field measurements between the simulator's outputs are read with t_field", {
  # a library-forming design: the sim_library is built at t_field
  heights <- c(1, 2, 3, 4, 5)
  design <- data.frame(r = rep(c(1, 2), each = 3), k = rep(1:3, 2))
  run <- function(r, k, h) k * h^2 / r
  simobs <- t(mapply(function(r, k) run(r, k, heights), design$r, design$k))
  t_field <- c(1.5, 4.2)
  expobs <- data.frame(r = c(2, 1), m1 = c(1, 2), m2 = c(9, 18))
  expect_message(
    out <- read_calibration_inputs(design, simobs, expobs, n_x = 1, t = heights,
                                   t_field = t_field),
    class = "griddy_message_interpolated")
  expect_s3_class(out$library, "sim_library")
  expect_identical(out$library$t, t_field)
  expect_equal(out$library$y[3, ], c(run(2, 3, t_field), run(1, 3, t_field)),
               tolerance = 1e-10)
  expect_identical(out$field$t, t_field)
  # calibrate() takes the pair with no reshaping by hand
  fit <- suppressWarnings(calibrate(out$library, out$field, n_iter = 200, burn_in = 50,
                                    seed = 1))
  expect_s3_class(fit, "griddy_fit")
  # expobs must hold the measurements at t_field, and t_field lie within t
  expect_error(suppressMessages(
    read_calibration_inputs(design, simobs, expobs, n_x = 1, t = heights,
                            t_field = c(1.5, 2, 4.2))),
    "3 measurements at `t_field`")
  expect_error(suppressMessages(
    read_calibration_inputs(design, simobs, expobs, n_x = 1, t = heights, t_field = c(0, 4))),
    "lie outside", class = "griddy_error_input")
})

test_that("t_field reaches an emulated library too (a joint design, SEPIA's layout)", {
  skip_if_not_installed("RobustGaSP")
  set.seed(3)
  heights <- seq(1, 6, by = 1)
  design <- data.frame(r = runif(20, 1, 2), k = runif(20, 1, 3))
  # one column per run, as the Los Alamos simobs code writes it
  simobs <- vapply(seq_len(20), function(i) design$k[i] * sqrt(heights) / design$r[i],
                   numeric(length(heights)))
  t_field <- c(2.5, 4.5)
  expobs <- data.frame(r = c(1.2, 1.8), m1 = c(2.6, 1.8), m2 = c(3.5, 2.4))
  out <- suppressMessages(read_calibration_inputs(design, simobs, expobs, n_x = 1,
                                                  t = heights, t_field = t_field,
                                                  n_runs = 50, seed = 1))
  expect_s3_class(out$library, "emulated_library")
  expect_identical(out$library$t, t_field)
  truth <- outer(out$library$theta$k, c(sqrt(t_field) / 1.2, sqrt(t_field) / 1.8))
  expect_lt(max(abs(out$library$y - truth)), 0.05)
})
