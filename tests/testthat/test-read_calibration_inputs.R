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
  expect_error(read_calibration_inputs(d$design[-4, ], d$simobs[-4, ], d$expobs, 1),
               "theta of `design` row 4 lacks setting\\(s\\) 1")
  expect_error(read_calibration_inputs(d$design, d$simobs,
                                       rbind(d$expobs, c(9, 0, 0)), 1),
               "No `design` run has the x setting\\(s\\) of `expobs` row\\(s\\) 4")
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
  expect_error(read_calibration_inputs(d$design, d$simobs, bad, 1), "`expobs` must hold finite numbers; found NA at \\[2, m1\\]")
  bad <- d$design
  bad$k <- as.character(bad$k)
  expect_error(read_calibration_inputs(bad, d$simobs, d$expobs, 1), "`design` must be numeric; column\\(s\\) k")
  expect_error(read_calibration_inputs("no-such-file.csv", d$simobs, d$expobs, 1), "`design` file not found")
  expect_error(read_calibration_inputs(d$design, d$simobs, d$expobs, -1), "`n_x`")
  expect_error(read_calibration_inputs(1:3, d$simobs, d$expobs, 1), "must be a file path, a data.frame or a matrix")
  one <- d$design$k == 5
  expect_error(read_calibration_inputs(d$design[one, ], d$simobs[one, ], d$expobs, 1),
               "`theta` must hold at least 2 runs")
})

test_that("runs at settings expobs lacks are dropped with a message", {
  d <- thesis_inputs()
  expect_message(out <- read_calibration_inputs(d$design, d$simobs, d$expobs[1:2, ], 1),
                 "2 `design` run\\(s\\) at x settings that `expobs` lacks were dropped \\(row\\(s\\) 1, 6\\)")
  expect_identical(out$library$y[1, ], c(351, 352, 151, 152))
})
