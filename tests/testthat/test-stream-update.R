# The stream's posterior and evidence against the batch ones on the same data.

test_that("one measurement at a time gives the batch posterior and evidence", {
  ex <- griddy_example()
  s <- griddy_stream(ex$library)
  y <- ex$field$y
  n_t <- ncol(y)
  for (k in seq_len(nrow(y))) {
    for (j in seq_len(n_t)) {
      s <- update(s, y = y[k, j], x = ex$field$x[k, , drop = FALSE], t = ex$library$t[j])
    }
  }
  expect_equal(nobs(s), length(y))
  batch <- posterior_exact(ex$library, ex$field)
  expect_equal(posterior_exact(s), batch, tolerance = 1e-10)
  expect_equal(as.numeric(logLik(s)), batch$log_evidence, tolerance = 1e-10)
})

test_that("an AR(1) grid over t is exact when each setting's t arrive in order", {
  ex <- griddy_example()
  rho_t <- c(0, 0.3, 0.8)
  s <- griddy_stream(ex$library, rho_t = rho_t)
  y <- ex$field$y
  # settings interleaved, each in increasing t, some outputs never measured
  set.seed(2)
  order_cells <- expand.grid(k = seq_len(nrow(y)), j = seq_len(ncol(y)))
  order_cells <- order_cells[order(order_cells$j), ]
  order_cells <- order_cells[-sample(nrow(order_cells), 10), ]
  for (m in seq_len(nrow(order_cells))) {
    k <- order_cells$k[m]
    j <- order_cells$j[m]
    update(s, y = y[k, j], x = ex$field$x[k, , drop = FALSE], t = ex$library$t[j])
  }
  both <- stream_vs_batch(s, ex$library, rho_t = rho_t)
  expect_equal(both$stream$run, both$batch$run, tolerance = 1e-10)
  expect_equal(both$stream$grid, both$batch$grid, tolerance = 1e-10)
  expect_equal(both$stream$log_evidence, both$batch$log_evidence, tolerance = 1e-10)
  # complete data in order: the Kronecker path of the batch
  s2 <- update(griddy_stream(ex$library, rho_t = rho_t), y = ex$field)
  expect_equal(posterior_exact(s2), posterior_exact(ex$library, ex$field, rho_t = rho_t),
               tolerance = 1e-10)
})

test_that("a measurement out of t order under AR(1) recomputes, with a message", {
  ex <- griddy_example()
  s <- griddy_stream(ex$library, rho_t = c(0, 0.6))
  x1 <- ex$field$x[1, , drop = FALSE]
  update(s, y = ex$field$y[1, 1:5], x = x1, t = ex$library$t[1:5])
  expect_message(update(s, y = ex$field$y[1, 8], x = x1, t = ex$library$t[8]), NA)
  expect_message(update(s, y = ex$field$y[1, 6], x = x1, t = ex$library$t[6]),
                 class = "griddy_message_stream_replay")
  both <- stream_vs_batch(s, ex$library, rho_t = c(0, 0.6))
  expect_equal(both$stream$run, both$batch$run, tolerance = 1e-10)
  expect_equal(both$stream$log_evidence, both$batch$log_evidence, tolerance = 1e-10)
  # and after the replay, updates stay incremental
  update(s, y = ex$field$y[1, 9], x = x1, t = ex$library$t[9])
  both <- stream_vs_batch(s, ex$library, rho_t = c(0, 0.6))
  expect_equal(both$stream$log_evidence, both$batch$log_evidence, tolerance = 1e-10)
  expect_error(update(s, y = 1, x = x1, t = ex$library$t[6]),
               class = "griddy_error_unsupported")
})

test_that("independent noise takes any order and replicates", {
  ex <- griddy_example()
  s <- griddy_stream(ex$library)
  set.seed(3)
  cells <- sample(length(ex$field$y))
  y <- as.vector(ex$field$y)
  k <- (cells - 1L) %% nrow(ex$field$y) + 1L
  j <- (cells - 1L) %/% nrow(ex$field$y) + 1L
  update(s, y = y[cells], x = ex$field$x[k, , drop = FALSE], t = ex$library$t[j])
  update(s, y = y[cells[1:4]] + 0.1, x = ex$field$x[k[1:4], , drop = FALSE],
         t = ex$library$t[j[1:4]])
  both <- stream_vs_batch(s, ex$library)
  expect_equal(both$stream$run, both$batch$run, tolerance = 1e-10)
  expect_equal(both$stream$log_evidence, both$batch$log_evidence, tolerance = 1e-10)
})

test_that("noise groups keep one form per group", {
  ex <- griddy_example()
  groups <- rep(c("early", "late"), each = 15)
  s <- update(griddy_stream(ex$library, rho_t = c(0, 0.5), noise_groups = groups),
              y = ex$field)
  batch <- posterior_exact(ex$library, ex$field, rho_t = c(0, 0.5), noise_groups = groups)
  expect_equal(posterior_exact(s), batch, tolerance = 1e-10)
  expect_equal(as.numeric(logLik(s)), batch$log_evidence, tolerance = 1e-10)
  s <- update(griddy_stream(ex$library, noise_groups = "x"), y = ex$field)
  batch <- posterior_exact(ex$library, ex$field, noise_groups = "x")
  expect_equal(posterior_exact(s)$run, batch$run, tolerance = 1e-10)
})

test_that("a field_data with missing cells is taken setting by setting", {
  ex <- griddy_example()
  y <- ex$field$y
  y[2, c(1, 5, 6)] <- NA
  field <- field_data(y, x = ex$field$x[c(2, 1, 3), , drop = FALSE][c(2, 1, 3), , drop = FALSE],
                      t = ex$library$t)
  s <- update(griddy_stream(ex$library, rho_t = c(0, 0.7)), y = field)
  expect_equal(nobs(s), sum(!is.na(y)))
  expect_equal(posterior_exact(s), posterior_exact(ex$library, field, rho_t = c(0, 0.7)),
               tolerance = 1e-10)
  expect_error(update(s, y = field, t = 1), class = "griddy_error_input")
})

test_that("a field_data reaches the stream's cells as it reaches calibrate()'s (issue 32)", {
  ex <- griddy_example()
  y <- ex$field$y
  x <- ex$field$x
  # settings given with floating noise, missing cells, a replicated setting
  noisy <- x
  noisy[[1]] <- noisy[[1]] * (1 + 1e-12)
  yy <- rbind(y, y[2, ] + 0.05)
  yy[1, c(3, 9)] <- NA
  yy[4, 1:10] <- NA
  field <- field_data(yy, x = noisy[c(1, 2, 3, 2), , drop = FALSE], t = ex$library$t)
  s <- update(griddy_stream(ex$library), y = field)
  expect_identical(nobs(s), sum(!is.na(yy)))
  expect_equal(posterior_exact(s), posterior_exact(ex$library, field), tolerance = 1e-10)
  # the stream now checks what calibrate() checks; it used to read these
  # fields silently (every row at the first setting; rows by position)
  one <- field_data(data.frame(t = ex$library$t[c(1, 1)], y = c(1, 2)))
  expect_error(posterior_exact(ex$library, one), "give the x columns")
  expect_error(update(griddy_stream(ex$library), y = one), "give the x columns")
  wrong <- field_data(y[1:2, ])
  expect_error(update(griddy_stream(ex$library), y = wrong), class = "griddy_error_shape")
})

test_that("a measurement that would overflow the forms is refused before it changes them", {
  ex <- griddy_example()
  x1 <- ex$field$x[1, , drop = FALSE]
  s <- griddy_stream(ex$library, rho_t = c(0, 0.5))
  update(s, y = ex$field$y[1, 1:3], x = x1, t = ex$library$t[1:3])
  # before: the forms took the infinite term, then the error; the stream
  # went on with infinite forms
  expect_error(update(s, y = 1e200, x = x1, t = ex$library$t[4]), class = "griddy_error_numeric")
  expect_identical(nobs(s), 3L)
  update(s, y = ex$field$y[1, 4:30], x = x1, t = ex$library$t[4:30])
  field <- field_data(ex$field$y[1, , drop = FALSE], x = x1, t = ex$library$t)
  expect_equal(posterior_exact(s), posterior_exact(ex$library, field, rho_t = c(0, 0.5)),
               tolerance = 1e-10)
})

test_that("a measurement's setting is matched as match_settings() matches it, column by column", {
  x_lib <- data.frame(a = c(0, 1, 1), b = c(2, 2, 3))
  x <- data.frame(b = c(3, 2 + 1e-12, 2), a = c(1, 1, 0))
  expect_identical(stream_settings(x, x_lib), match_settings(x, x_lib))
  expect_identical(stream_settings(x, x_lib), c(3L, 2L, 1L))
  expect_error(stream_settings(data.frame(a = 1, b = 5), x_lib), "does not have")
  expect_error(stream_settings(data.frame(a = 1, c = 2), x_lib), "column")
})

test_that("measurements one at a time with their x and t, some cells never measured, give the batch posterior", {
  ex <- griddy_example()
  y <- ex$field$y
  set.seed(11)
  skip_cells <- sample(length(y), round(0.2 * length(y)))
  y_missing <- y
  y_missing[skip_cells] <- NA
  s <- griddy_stream(ex$library, rho_t = c(0, 0.5, 0.9))
  for (k in seq_len(nrow(y))) {
    for (j in seq_len(ncol(y))) {
      if (is.na(y_missing[k, j])) next
      update(s, y = y[k, j], x = ex$field$x[k, , drop = FALSE], t = ex$library$t[j])
    }
  }
  batch <- posterior_exact(ex$library, field_data(y_missing, x = ex$field$x, t = ex$library$t),
                           rho_t = c(0, 0.5, 0.9), joint = FALSE)
  streamed <- posterior_exact(s, joint = FALSE)
  expect_lt(max(abs(streamed$run - batch$run)), 1e-10)
  expect_lt(abs(streamed$log_evidence / batch$log_evidence - 1), 1e-10)
})

test_that("a batch goes in in one pass with the forms one measurement at a time gives", {
  ex <- griddy_example()
  cells <- stream_cells(ex$library, ex$field)
  batch <- update(griddy_stream(ex$library, rho_t = c(0, 0.5)), y = ex$field)
  single <- griddy_stream(ex$library, rho_t = c(0, 0.5))
  n_t <- length(ex$library$t)
  for (m in seq_along(cells$column)) {
    k <- (cells$column[m] - 1L) %/% n_t + 1L
    update(single, y = cells$y[m], x = ex$field$x[k, , drop = FALSE],
           t = ex$library$t[(cells$column[m] - 1L) %% n_t + 1L])
  }
  expect_identical(batch$state$C, single$state$C)
  expect_length(batch$state$pending, 0L)
})

test_that("a measurement refused part-way through a batch leaves the ones before it in the forms", {
  ex <- griddy_example()
  n_t <- length(ex$library$t)
  x1 <- ex$field$x[1, , drop = FALSE]
  s <- griddy_stream(ex$library, rho_t = c(0, 0.5))
  # the third value repeats the first (x, t): a replicate under AR(1) is refused
  expect_error(update(s, y = ex$field$y[1, c(1, 2, 1)], x = x1, t = ex$library$t[c(1, 2, 1)]),
               class = "griddy_error_unsupported")
  expect_equal(nobs(s), 2L)
  ref <- update(griddy_stream(ex$library, rho_t = c(0, 0.5)), y = ex$field$y[1, 1:2], x = x1,
                t = ex$library$t[1:2])
  expect_identical(s$state$C, ref$state$C)
})
