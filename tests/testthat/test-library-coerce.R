test_that("as.data.frame() gives theta and as.matrix() the outputs of every backend", {
  toy <- toy_xt(n_per_dim = 5)
  mem <- toy$library
  libs <- list(sim = mem)
  rds_dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(mem, rds_dir, chunk_size = 7)
  libs$disk <- disk_library(rds_dir, trust = TRUE)
  if (requireNamespace("hdf5r", quietly = TRUE)) {
    h5 <- withr::local_tempfile(fileext = ".h5")
    libs$hdf5 <- write_library(mem, h5, chunk_size = 4)
  }
  for (nm in names(libs)) {
    th <- as.data.frame(libs[[nm]])
    expect_s3_class(th, "data.frame")
    expect_identical(th, `rownames<-`(as.data.frame(mem$theta), NULL), info = nm)
    y <- as.matrix(libs[[nm]])
    expect_identical(y, unname(mem$y), info = nm)
    expect_identical(dim(y), c(lib_n_runs(mem), lib_n_x(mem) * lib_n_t(mem)))
  }
})

test_that("as.data.frame() and as.matrix() of emulated and refined libraries go through the interface", {
  skip_if_not_installed("RobustGaSP")
  emu <- emulated_toy_library(n = 30, n_runs = 200)
  expect_identical(as.data.frame(emu), `rownames<-`(as.data.frame(lib_theta(emu)), NULL))
  expect_identical(as.matrix(emu), unname(lib_outputs(emu)))
  expect_identical(nrow(as.matrix(emu)), 200L)
  toy <- refine_toy()
  refined <- suppressWarnings(suppressMessages(
    refine(toy$fit, refine_sim, max_runs = 60, seed = 1, progress = FALSE)))
  lib <- refined$library
  expect_s3_class(lib, "refined_library")
  expect_gt(lib_n_runs(lib), lib_n_runs(toy$lib))
  expect_identical(as.data.frame(lib)$k, lib_theta(lib)$k)
  y <- as.matrix(lib)
  expect_identical(y[seq_len(lib_n_runs(toy$lib)), ], unname(toy$lib$y))
  added <- as.data.frame(lib)[-seq_len(lib_n_runs(toy$lib)), , drop = FALSE]
  expect_equal(y[-seq_len(lib_n_runs(toy$lib)), , drop = FALSE], unname(refine_sim(added)))
})

test_that("as.matrix() checks the size before reading, with a classed error naming it", {
  toy <- toy_ar1(n_runs = 50, n_t = 10)
  err <- expect_error(as.matrix(toy$library, max_bytes = 1000), class = "griddy_error_memory")
  expect_match(conditionMessage(err), "50 runs x 10 outputs = 4 kB, more than `max_bytes` \\(1 kB\\)")
  withr::with_options(list(griddy.max_bytes = 3999),
                      expect_error(as.matrix(toy$library), class = "griddy_error_memory"))
  expect_identical(dim(as.matrix(toy$library, max_bytes = 4000)), c(50L, 10L))
  expect_error(as.matrix(toy$library, max_bytes = -1), "`max_bytes` must be a positive number")
  # a library on disk is refused before any chunk is read
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(toy$library, dir, chunk_size = 20)
  lib <- disk_library(dir, trust = TRUE)
  unlink(file.path(dir, "chunk-000001.rds"))
  expect_error(as.matrix(lib, max_bytes = 1000), class = "griddy_error_memory")
  # and so is an HDF5 library
  skip_if_not_installed("hdf5r")
  h5 <- write_library(toy$library, withr::local_tempfile(fileext = ".h5"), chunk_size = 20)
  expect_error(as.matrix(h5, max_bytes = 1000), class = "griddy_error_memory")
  expect_identical(dim(as.matrix(h5, max_bytes = 4000)), c(50L, 10L))
})
