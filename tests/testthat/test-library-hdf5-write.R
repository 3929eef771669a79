skip_if_not_installed("hdf5r")

test_that("write_library() writes, appends and converts; reads are chunked", {
  toy <- toy_xt(n_per_dim = 7)
  lib <- toy$library
  file <- withr::local_tempfile(fileext = ".h5")
  h5 <- write_library(lib_rows(lib, 1:20), file, chunk_size = 6)
  expect_identical(h5$n_runs, 20L)
  expect_error(write_library(lib_rows(lib, 21:49), file), "already exists")
  expect_error(write_library(lib_rows(lib, 15:30), file, append = TRUE), "duplicated runs")
  h5 <- write_library(lib_rows(lib, 21:49), file, append = TRUE)
  expect_output(print(h5), "written by write_library\\(\\): 49 committed runs")
  expect_identical(lib_outputs(h5), lib$y)
  expect_identical(h5$theta, lib$theta)
  expect_identical(h5$x, lib$x)
  small <- hdf5_library(file, chunk_size = 5)
  expect_identical(lib_outputs(small, c(49L, 1L, 6L, 5L, 6L)), lib$y[c(49, 1, 6, 5, 6), ])
  expect_identical(lib_quad_forms(small, toy$field$y, correlation_setup(lib, 0.3, 0.5)),
                   lib_quad_forms(lib, toy$field$y, correlation_setup(lib, 0.3, 0.5)))
  other <- sim_library(data.frame(a = c(9, 8), z = c(1, 2)), lib$y[1:2, ], x = lib$x,
                       t = lib$t)
  expect_error(write_library(other, file, append = TRUE), "its parameters differ")
  other <- sim_library(lib$theta[c(1, 9), ], lib$y[1:2, ], x = lib$x, t = lib$t + 1)
  expect_error(write_library(other, file, append = TRUE), "coordinates t differ")
  expect_error(write_library(lib, tempfile(), append = TRUE), "holds no library to append to")
  expect_error(write_library(lib, 3), "`file` must be a single non-empty string")
  # a copy: from one HDF5 library to another, a piece at a time
  file2 <- withr::local_tempfile(fileext = ".h5")
  expect_identical(lib_outputs(write_library(small, file2)), lib$y)
  # a user's file is read, not appended to
  file3 <- withr::local_tempfile(fileext = ".h5")
  write_user_h5(lib, file3)
  expect_error(write_library(lib, file3, append = TRUE), "was not written by write_library")
  expect_error(repair_library(file3), "was not written by write_library")
})


test_that("an append that fails part-way leaves the committed library and cuts its own rows", {
  toy <- toy_ar1(n_runs = 40, n_t = 6)
  lib <- toy$library
  file <- withr::local_tempfile(fileext = ".h5")
  write_library(lib_rows(lib, 1:20), file, chunk_size = 4)
  for (step in c("extended", "piece", "rows_written")) {
    withr::with_options(list(griddy.write_hook = function(s) if (s == step) stop("injected")), {
      expect_error(write_library(lib_rows(lib, 21:30), file, append = TRUE), "injected")
    })
    expect_false(dir.exists(paste0(file, ".lock"))) # the lock went with the writer
    expect_silent(h5 <- hdf5_library(file)) # the failed append cut its rows
    expect_identical(lib_outputs(h5), lib$y[1:20, ])
    expect_identical(posterior_exact(h5, toy$field)$joint,
                     posterior_exact(lib_rows(lib, 1:20), toy$field)$joint)
  }
  # rows a writer that died left past the count: ignored, then discarded
  leave_uncommitted(file, lib_rows(lib, 21:30))
  expect_warning(h5 <- hdf5_library(file), paste0(
    "holds 10 uncommitted run\\(s\\) past its 20 committed runs.*repair_library"),
    class = "griddy_warning_library")
  expect_identical(lib_outputs(h5), lib$y[1:20, ])
  expect_message(res <- repair_library(file), "holds 20 runs; 10 uncommitted run\\(s\\) discarded")
  expect_identical(res$dropped, 10L)
  expect_silent(h5 <- hdf5_library(file))
  leave_uncommitted(file, lib_rows(lib, 21:30))
  expect_warning(h5 <- write_library(lib_rows(lib, 21:40), file, append = TRUE),
                 "Discarded 10 uncommitted run\\(s\\)")
  expect_identical(lib_outputs(h5), lib$y)
  expect_identical(h5$theta, lib$theta)
  # a first write that dies leaves no file
  file2 <- withr::local_tempfile(fileext = ".h5")
  withr::with_options(list(griddy.write_hook = function(s) if (s == "locked") stop("injected")), {
    expect_error(write_library(lib, file2), "injected")
  })
  expect_false(file.exists(file2))
})


test_that("a full disk during an append ends in a griddy_error_disk, no crash, the file intact", {
  # a real write failure: a child R process under a file-size limit (ulimit
  # -f), where writes past it fail with EFBIG as on a full disk. Before, the
  # append stopped in hdf5r's raw error and the next gc() crashed R in
  # hdf5r's finalizer (the child's exit status was 139, a segfault).
  skip_on_cran()
  skip_on_os("windows")
  toy <- toy_ar1(n_runs = 6000, n_t = 50)
  file <- withr::local_tempfile(fileext = ".h5")
  write_library(lib_rows(toy$library, 1:100), file)
  piece <- tempfile(fileext = ".rds")
  saveRDS(lib_rows(toy$library, 101:6000), piece) # 2.4 MB of outputs
  result <- tempfile()
  code <- c(sprintf("piece <- readRDS(%s)", deparse(piece)),
            sprintf("out <- tryCatch({write_library(piece, %s, append = TRUE); 'ok'},",
                    deparse(file)),
            "  error = function(e) paste(class(e)[1], conditionMessage(e)))",
            "invisible(gc()); invisible(gc())",
            sprintf("writeLines(out, %s)", deparse(result)))
  limit_kb <- ceiling(file.size(file) / 1024) + 1000 # room for 1 MB more, not 2.4
  status <- run_child_limited(code, limit_kb)
  expect_identical(status, 0L) # no segfault, at gc() or at exit
  out <- readLines(result)
  expect_match(out[1], "^griddy_error_disk Writing .* failed: the disk is full")
  expect_silent(h5 <- hdf5_library(file))
  expect_identical(h5$n_runs, 100L)
  expect_identical(lib_outputs(h5), toy$library$y[1:100, ])
  expect_message(repair_library(file), "holds 100 runs; nothing to repair")
  h5 <- write_library(lib_rows(toy$library, 101:6000), file, append = TRUE) # space again
  expect_identical(h5$n_runs, 6000L)
})


test_that("a writer waits for a reader that holds the file open, and is refused after `wait`", {
  skip_if_not_installed("hdf5r")
  skip_on_cran()
  toy <- toy_ar1(n_runs = 30, n_t = 8)
  file <- withr::local_tempfile(fileext = ".h5")
  write_library(lib_rows(toy$library, 1:10), file)
  # another process reads the file (HDF5's shared lock) for 2 s
  marker <- withr::local_tempfile()
  reader <- sprintf(paste0("h5 <- hdf5r::H5File$new(%s, 'r'); invisible(file.create(%s)); ",
                           "Sys.sleep(2); h5$close_all()"), deparse(file), deparse(marker))
  system2(file.path(R.home("bin"), "Rscript"), c("-e", shQuote(reader)), wait = FALSE)
  wait_for_file(marker)
  expect_error(h5_open(file, "r+", wait = 0), "held open by another process",
               class = "griddy_error_lock")
  start <- proc.time()[["elapsed"]]
  lib <- write_library(lib_rows(toy$library, 11:30), file, append = TRUE)
  expect_gt(proc.time()[["elapsed"]] - start, 0.5)  # it waited for the reader
  expect_identical(lib_outputs(lib), unname(toy$library$y))
})


test_that("HDF5's raw write errors become classed: griddy_error_disk for a full disk, else _io", {
  file <- "/somewhere/lib.h5"
  full <- simpleError(paste0("HDF5-API Errors:\n error #001: H5FDsec2.c in H5FD__sec2_write(): ",
                             "file write failed: errno = 28, error message = 'No space left ",
                             "on device'\n minor: Write failed"))
  err <- expect_error(h5_guard_write(file, stop(full)), class = "griddy_error_disk")
  expect_match(conditionMessage(err), paste0("the disk is full.*No space left on device.*",
                                             "repair_library\\(\"/somewhere/lib.h5\"\\)"))
  other <- simpleError("HDF5-API Errors:\n minor: Unable to initialize object")
  expect_error(h5_guard_write(file, stop(other)), "unable to initialize object",
               class = "griddy_error_io")
  # griddy's own errors pass through unchanged
  expect_error(h5_guard_write(file, griddy_abort("mine", class = "shape")), "^mine$",
               class = "griddy_error_shape")
})


test_that("simulate_library() on a device that fills up (a small tmpfs): griddy_error_disk, the runs committed so far kept", {
  skip_on_cran()
  skip_on_os(c("windows", "mac"))
  dir <- withr::local_tempfile(pattern = "tmpfs-")
  dir.create(dir)
  status <- suppressWarnings(system2("mount", c("-t", "tmpfs", "-o", "size=3m", "tmpfs", dir),
                                     stdout = FALSE, stderr = FALSE))
  skip_if(!identical(status, 0L), "cannot mount a tmpfs here (not root, or no mount)")
  on.exit(system2("umount", dir), add = TRUE)
  tt <- seq(0, 1, length.out = 50)
  sim <- function(theta) t(vapply(theta$k, function(k) sin(k * tt), numeric(50)))
  design <- data.frame(k = seq(1, 4, length.out = 10000)) # 4 MB of outputs
  file <- file.path(dir, "lib.h5")
  expect_error(simulate_library(sim, design, file, t = tt, progress = FALSE),
               "the disk is full", class = "griddy_error_disk")
  invisible(gc())
  expect_silent(lib <- hdf5_library(file))
  expect_gt(lib$n_runs, 0L)
  expect_identical(lib_outputs(lib, lib$n_runs), sim(lib$theta[lib$n_runs, , drop = FALSE]))
  expect_message(repair_library(file), "nothing to repair")
})
