skip_if_not_installed("hdf5r")

test_that("a user's HDF5 file is read in both orientations, without conversion", {
  toy <- toy_xt(n_per_dim = 5)
  lib <- toy$library
  for (layout in c("runs_first", "runs_last")) {
    for (theta_as in c("compound", "matrix")) {
      file <- withr::local_tempfile(fileext = ".h5")
      write_user_h5(lib, file, layout = layout, theta_as = theta_as)
      h5 <- hdf5_library(file, theta = "params", outputs = "sim/out", x = lib$x,
                         t = "sim/time", chunk_size = 7)
      expect_s3_class(h5, "hdf5_library")
      expect_identical(h5$layout, layout)
      expect_identical(h5$theta, lib$theta)
      expect_identical(h5$t, lib$t)
      expect_identical(lib_outputs(h5), lib$y)
      expect_identical(lib_outputs(h5, c(25L, 3L, 8L, 3L)), lib$y[c(25, 3, 8, 3), ])
      # an explicit layout gives the same
      h5b <- hdf5_library(file, theta = "params", outputs = "sim/out", x = lib$x,
                          t = "sim/time", layout = layout)
      expect_identical(lib_outputs(h5b), lib$y)
    }
  }
  expect_output(print(h5), "<hdf5_library> 25 runs of 2 parameter\\(s\\)")
  expect_output(print(h5), "from dataset 'sim/out', runs last in HDF5's order; read 7 runs")
})

test_that("parameter names come from the user, the fields or an attribute", {
  toy <- toy_ar1(n_runs = 20, n_t = 6)
  file <- withr::local_tempfile(fileext = ".h5")
  write_user_h5(toy$library, file, layout = "runs_first", theta_as = "bare")
  expect_error(hdf5_library(file, theta = "params", outputs = "sim/out"),
               "'params'.*without column names: give them with `theta_names`")
  # one parameter: a one-dimensional dataset read as runs_first 20 x 1
  h5 <- hdf5_library(file, theta = "params", outputs = "sim/out", theta_names = "theta")
  expect_identical(h5$theta, toy$library$theta)
  expect_identical(h5$t, as.double(1:6))
  # compound: theta_names selects and orders the fields
  file2 <- withr::local_tempfile(fileext = ".h5")
  lib2 <- toy_xt(n_per_dim = 4)$library
  write_user_h5(lib2, file2, theta_as = "compound")
  h5 <- hdf5_library(file2, theta = "params", outputs = "sim/out", x = lib2$x,
                     theta_names = c("b", "a"))
  expect_identical(names(h5$theta), c("b", "a"))
  expect_error(hdf5_library(file2, theta = "params", outputs = "sim/out", x = lib2$x,
                            theta_names = c("a", "z")), "has no field\\(s\\) z")
})

test_that("an ambiguous or mismatched orientation is refused", {
  # 3 runs of 3 outputs and 3 parameters: either dimension could be the runs
  theta <- data.frame(a = c(1, 2, 3), b = c(3, 1, 2), c = c(0, 1, 5))
  lib <- sim_library(theta, matrix(as.double(1:9), 3))
  file <- withr::local_tempfile(fileext = ".h5")
  write_user_h5(lib, file, layout = "runs_last", theta_as = "matrix")
  expect_error(hdf5_library(file, theta = "params", outputs = "sim/out"),
               "orientation is ambiguous.*Give `layout = \"runs_first\"`",
               class = "griddy_error_shape")
  h5 <- hdf5_library(file, theta = "params", outputs = "sim/out", layout = "runs_last")
  expect_identical(lib_outputs(h5), lib$y)
  expect_identical(h5$theta, lib$theta)
  # per-dataset layouts
  h5 <- hdf5_library(file, theta = "params", outputs = "sim/out",
                     layout = c(theta = "runs_last", outputs = "runs_last"))
  expect_identical(lib_outputs(h5), lib$y)
  # the wrong explicit layout, when the sizes show it
  toy <- toy_ar1(n_runs = 20, n_t = 6)
  file2 <- withr::local_tempfile(fileext = ".h5")
  write_user_h5(toy$library, file2, layout = "runs_first")
  expect_error(hdf5_library(file2, theta = "params", outputs = "sim/out", layout = "runs_last"),
               "is 20 x 6 \\(in HDF5's order.*does not fit layout \"runs_last\" with 20 runs",
               class = "griddy_error_shape")
  # outputs with another number of runs than theta
  h <- hdf5r::H5File$new(file2, "r+")
  h[["short"]] <- t(toy$library$y[1:19, ])
  h$close_all()
  expect_error(hdf5_library(file2, theta = "params", outputs = "short"),
               "neither dimension fits 20 runs", class = "griddy_error_shape")
  expect_error(hdf5_library(file2, theta = "params", outputs = "nothing"),
               "has no dataset 'nothing'; its datasets are 'params', 'short', 'sim/out'")
  expect_error(hdf5_library(file2, theta = "params", outputs = "sim/out", layout = "sideways"),
               "`layout` must be")
  expect_error(hdf5_library(tempfile()), "does not exist")
  writeLines("not hdf5", file2)
  expect_error(hdf5_library(file2), "cannot be opened as an HDF5 file: not an hdf5 file",
               class = "griddy_error_library")
})

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

test_that("the outputs are checked as they are read", {
  toy <- toy_ar1(n_runs = 30, n_t = 6)
  y <- toy$library$y
  y[17, 2] <- NA
  file <- withr::local_tempfile(fileext = ".h5")
  h <- hdf5r::H5File$new(file, "w")
  h[["theta"]] <- toy$library$theta
  h[["y"]] <- y
  h$close_all()
  h5 <- hdf5_library(file, chunk_size = 10)
  expect_error(posterior_exact(h5, toy$field),
               "Dataset 'y' of .* \\(runs 11 to 20\\) holds non-finite outputs \\(NA\\) at run\\(s\\) 17",
               class = "griddy_error_library")
  expect_identical(lib_outputs(h5, 1:10), toy$library$y[1:10, ])
  # the file changed after it was opened
  h <- hdf5r::H5File$new(file, "r+")
  h$link_delete("y")
  h[["y"]] <- toy$library$y[1:25, ]
  h$close_all()
  expect_error(lib_outputs(h5, 28), "is now 6 x 25 .* the file changed after it was opened",
               class = "griddy_error_library")
})

test_that("an edited hdf5_library is a shape error before any C++", {
  toy <- toy_ar1(n_runs = 30, n_t = 6)
  file <- withr::local_tempfile(fileext = ".h5")
  h5 <- write_library(toy$library, file)
  bad <- h5
  bad$theta$theta[2] <- NA
  expect_error(posterior_exact(bad, toy$field), "hdf5_library has been edited.*NA at \\[2, theta\\]",
               class = "griddy_error_shape")
  bad <- h5
  bad$theta <- bad$theta[-1, , drop = FALSE]
  expect_error(calibrate(bad, toy$field, n_iter = 100, burn_in = 10),
               "`theta` has 29 rows but the library holds 30 runs", class = "griddy_error_shape")
  bad <- h5
  bad$n_out <- 5L
  expect_error(posterior_exact(bad, toy$field), "library holds 5", class = "griddy_error_shape")
  bad <- h5
  bad$layout <- "sideways"
  expect_error(check_library(bad), "hdf5_library has been edited", class = "griddy_error_shape")
  bad <- h5
  bad$theta$theta <- as.integer(seq_len(30))
  expect_error(check_library(bad), "data.frame of double", class = "griddy_error_shape")
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

test_that("HDF5 chunks mapped on two future workers give the same C and draws", {
  skip_on_cran()
  skip_if_not_installed("future.apply")
  skip_if_not(installed_griddy_is_current("hdf5_library"),
              "the installed griddy is not this version")
  toy <- toy_xt(n_per_dim = 7) # 49 runs x 36 outputs: not ambiguous
  file <- withr::local_tempfile(fileext = ".h5")
  write_user_h5(toy$library, file, layout = "runs_first")
  lib <- hdf5_library(file, theta = "params", outputs = "sim/out", x = toy$library$x,
                      t = "sim/time", chunk_size = 10)
  serial <- posterior_exact(lib, toy$field, rho_t = c(0, 0.5))
  old <- future::plan(future::multisession, workers = 2)
  on.exit(future::plan(old), add = TRUE)
  expect_identical(posterior_exact(lib, toy$field, rho_t = c(0, 0.5))$joint, serial$joint)
  a <- without_resolution_warning(
    calibrate(lib, toy$field, rho_t = c(0, 0.5), n_iter = 400, burn_in = 100, seed = 2))
  future::plan(future::sequential)
  b <- without_resolution_warning(
    calibrate(lib, toy$field, rho_t = c(0, 0.5), n_iter = 400, burn_in = 100, seed = 2))
  expect_identical(a$draws, b$draws)
})

test_that("uncommitted rows are never read as theta, whatever they hold", {
  # found by R CMD check: rows past the committed count hold whatever was on
  # disk (fill values are off), and a NaN there failed the theta check
  skip_if_not_installed("hdf5r")
  toy <- toy_ar1(n_runs = 40, n_t = 6)
  file <- withr::local_tempfile(fileext = ".h5")
  write_library(lib_rows(toy$library, 1:20), file, chunk_size = 4)
  leave_uncommitted(file, lib_rows(toy$library, 21:30))
  h5 <- hdf5r::H5File$new(file, "r+")
  h5[["theta"]][21:30, 1] <- rep(NaN, 10)
  h5$close_all()
  expect_warning(lib <- hdf5_library(file), "10 uncommitted run", class = "griddy_warning_library")
  expect_identical(lib$theta, toy$library$theta[1:20, , drop = FALSE])
})

test_that("a file claiming more runs than it stores is refused before allocating (issue 22)", {
  skip_if_not_installed("hdf5r")
  # 1.7 kB on disk, datasets of 10^9 runs that were never written: reading
  # theta allocated 7.5 GB
  file <- withr::local_tempfile(fileext = ".h5")
  h5 <- hdf5r::H5File$new(file, "w")
  h5$create_dataset("theta", space = hdf5r::H5S$new(dims = 1e9, maxdims = 1e9),
                    dtype = hdf5r::h5types$H5T_NATIVE_DOUBLE, chunk_dims = 1e6)
  h5$create_dataset("y", space = hdf5r::H5S$new(dims = c(1e9, 3), maxdims = c(1e9, 3)),
                    dtype = hdf5r::h5types$H5T_NATIVE_DOUBLE, chunk_dims = c(1e5, 1))
  h5$close_all()
  expect_lt(file.size(file), 1e4)
  err <- expect_error(hdf5_library(file, theta_names = "k"), class = "griddy_error_library")
  expect_match(conditionMessage(err), paste0("dataset 'theta' in .* claims 1,000,000,000 entries \\(8 GB\\).*",
                                             "stores 0 B"))
  # the outputs are checked too (they are read later, a chunk at a time)
  toy <- toy_ar1(n_runs = 10, n_t = 3)
  file2 <- withr::local_tempfile(fileext = ".h5")
  h5 <- hdf5r::H5File$new(file2, "w")
  h5[["theta"]] <- seq_len(1e6) / 1e6
  h5$create_dataset("y", space = hdf5r::H5S$new(dims = c(1e6, 3), maxdims = c(1e6, 3)),
                    dtype = hdf5r::h5types$H5T_NATIVE_DOUBLE, chunk_dims = c(1e5, 1))
  h5$close_all()
  expect_error(hdf5_library(file2, theta_names = "k"), "dataset 'y' in .* stores 0 B",
               class = "griddy_error_library")
})

test_that("a tampered committed-run count is a classed error naming the file and attribute (issue 22)", {
  skip_if_not_installed("hdf5r")
  toy <- toy_ar1(n_runs = 20, n_t = 4)
  file <- withr::local_tempfile(fileext = ".h5")
  write_library(toy$library, file)
  for (bad in list("many", 1e10, -3, 2.5, c(5, 6), NA_real_)) {
    h5 <- hdf5r::H5File$new(file, "r+")
    h5$attr_delete("griddy_n_runs")
    hdf5r::h5attr(h5, "griddy_n_runs") <- bad
    h5$close_all()
    err <- expect_error(hdf5_library(file), class = "griddy_error_library")
    expect_match(conditionMessage(err), "is damaged.*attribute griddy_n_runs")
    expect_match(conditionMessage(err), basename(file), fixed = TRUE)
  }
})

test_that("an HDF5 library of 0 runs is a classed error (issue 22)", {
  skip_if_not_installed("hdf5r")
  file <- withr::local_tempfile(fileext = ".h5")
  h5 <- hdf5r::H5File$new(file, "w")
  h5[["theta"]] <- numeric(0)
  h5[["y"]] <- matrix(numeric(0), 0, 3)
  h5$close_all()
  expect_error(hdf5_library(file, theta_names = "k"), "holds 0 runs",
               class = "griddy_error_library_size")
  toy <- toy_ar1(n_runs = 10, n_t = 3)
  own <- withr::local_tempfile(fileext = ".h5")
  write_library(toy$library, own)
  h5 <- hdf5r::H5File$new(own, "r+")
  h5$attr_delete("griddy_n_runs")
  hdf5r::h5attr(h5, "griddy_n_runs") <- 0
  h5$close_all()
  expect_error(suppressWarnings(hdf5_library(own)), "committed runs\\) holds 0 runs",
               class = "griddy_error_library_size")
})

test_that("print.hdf5_library() shows the runs, the dataset and the chunks", {
  toy <- toy_xt(n_per_dim = 4)
  file <- withr::local_tempfile(fileext = ".h5")
  write_user_h5(toy$library, file)
  h5 <- hdf5_library(file, theta = "params", outputs = "sim/out", x = toy$library$x,
                     t = "sim/time", chunk_size = 7)
  expect_snapshot(print(h5), transform = scrub_print)
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

test_that("string datasets: numbers kept as text are read, other text is refused as unsupported, not damaged", {
  # before, a string dataset's variable size made the stored-size check
  # claim NA bytes and call the file damaged (griddy_error_library)
  toy <- toy_ar1(n_runs = 3000, n_t = 100)
  lib <- toy$library
  h5_file <- function(fill) {
    f <- withr::local_tempfile(fileext = ".h5", .local_envir = parent.frame())
    h5 <- hdf5r::H5File$new(f, "w")
    fill(h5)
    h5$close_all()
    f
  }
  f <- h5_file(function(h5) {
    h5[["params"]] <- format(lib$theta$theta, digits = 17)
    h5[["out"]] <- lib$y
    h5[["time"]] <- as.character(lib$t)
  })
  h5 <- hdf5_library(f, theta = "params", outputs = "out", theta_names = "theta", t = "time")
  expect_equal(h5$theta, lib$theta)
  expect_equal(h5$t, lib$t)
  f <- h5_file(function(h5) {
    h5[["params"]] <- paste0("run", seq_len(3000))
    h5[["out"]] <- lib$y
  })
  expect_error(hdf5_library(f, theta = "params", outputs = "out", theta_names = "theta"),
               "holds text .* entry 1 is \"run1\"", class = "griddy_error_unsupported")
  f <- h5_file(function(h5) {
    h5[["params"]] <- lib$theta
    h5[["out"]] <- matrix(format(lib$y), nrow(lib$y))
  })
  expect_error(hdf5_library(f, theta = "params", outputs = "out"),
               "holds text \\(an HDF5 string dataset\\), which griddy does not read as outputs",
               class = "griddy_error_unsupported")
  f <- h5_file(function(h5) {
    h5[["params"]] <- data.frame(theta = lib$theta$theta, label = paste0("run", 1:3000))
    h5[["out"]] <- lib$y
  })
  expect_error(hdf5_library(f, theta = "params", outputs = "out"),
               "text field\\(s\\) label.*theta_names = c\\(\"theta\"\\)",
               class = "griddy_error_unsupported")
  h5 <- hdf5_library(f, theta = "params", outputs = "out", theta_names = "theta")
  expect_identical(h5$theta, lib$theta)
})

test_that("a reader calibrates while another process appends (SWMR): never refused, a committed prefix", {
  # before, HDF5 refused every reader for the length of an append (39 of 40
  # reads in a minute during a campaign)
  skip_on_cran()
  skip_on_os("windows")
  toy <- toy_ar1(n_runs = 1200, n_t = 10)
  lib <- toy$library
  file <- withr::local_tempfile(fileext = ".h5")
  write_library(lib_rows(lib, 1:200), file)
  expect_true(h5_swmr_capable(file))
  piece <- tempfile(fileext = ".rds")
  saveRDS(lib, piece)
  started <- tempfile()
  done <- tempfile()
  # ten appends of 100 runs, each holding the file open (extended, not yet
  # committed) for 0.3 s
  run_child(c(sprintf("lib <- readRDS(%s)", deparse(piece)),
              "options(griddy.write_hook = function(s) if (s == 'piece') Sys.sleep(0.3))",
              sprintf("file.create(%s)", deparse(started)),
              "for (j in 1:10) {",
              "  rows <- 200 + (j - 1) * 100 + 1:100",
              "  part <- sim_library(lib$theta[rows, , drop = FALSE], lib$y[rows, ], t = lib$t)",
              sprintf("  write_library(part, %s, append = TRUE)", deparse(file)),
              "}",
              sprintf("writeLines('ok', %s)", deparse(done))), wait = FALSE)
  wait_for_file(started, timeout = 120)
  seen <- integer(0)
  while (!file.exists(done) || length(seen) < 2L) {
    expect_silent(h5 <- hdf5_library(file)) # no error, no warning: the committed runs
    n <- h5$n_runs
    expect_true(n %in% seq(200L, 1200L, by = 100L))
    expect_identical(lib_outputs(h5), lib$y[seq_len(n), ])
    # (the toy's resolution and gap warnings are not what is tested here)
    fit <- suppressWarnings(calibrate(h5, toy$field, n_iter = 200, burn_in = 50, seed = 1))
    expect_identical(nrow(fit$C), n) # one row per run read
    seen <- c(seen, n)
  }
  expect_identical(readLines(done), "ok")
  expect_identical(hdf5_library(file)$n_runs, 1200L)
  expect_gt(length(unique(seen)), 1L) # the reads saw the appends land
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
  status <- suppressWarnings(system2("mount", c("-t", "tmpfs", "-o", "size=8m", "tmpfs", dir),
                                     stdout = FALSE, stderr = FALSE))
  skip_if(!identical(status, 0L), "cannot mount a tmpfs here (not root, or no mount)")
  on.exit(system2("umount", dir), add = TRUE)
  tt <- seq(0, 1, length.out = 50)
  sim <- function(theta) t(vapply(theta$k, function(k) sin(k * tt), numeric(50)))
  design <- data.frame(k = seq(1, 4, length.out = 20000)) # 8 MB of outputs
  file <- file.path(dir, "lib.h5")
  expect_error(simulate_library(sim, design, file, t = tt, progress = FALSE),
               "the disk is full", class = "griddy_error_disk")
  invisible(gc())
  expect_silent(lib <- hdf5_library(file))
  expect_gt(lib$n_runs, 0L)
  expect_identical(lib_outputs(lib, lib$n_runs), sim(lib$theta[lib$n_runs, , drop = FALSE]))
  expect_message(repair_library(file), "nothing to repair")
})
