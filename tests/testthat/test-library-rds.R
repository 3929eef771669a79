test_that("an old .rds chunk directory gives the in-memory C, exact posterior and draws", {
  toy <- toy_xt(n_per_dim = 9)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(toy$library, dir, chunk_size = 20)
  lib <- disk_library(dir, trust = TRUE)
  expect_s3_class(lib, "disk_library")
  expect_length(lib$files, 5)
  expect_identical(lib$rows, c(20L, 20L, 20L, 20L, 1L))
  expect_output(print(lib), "81 runs of 2 parameter\\(s\\) in 5 .rds chunk\\(s\\)")
  rho <- list(rho_x = c(0, 0.3), rho_t = c(0, 0.5))
  mem <- local_problem(toy$library, toy$field, rho_x = rho$rho_x, rho_t = rho$rho_t,
                       prior = list(shape = 1e-9, rate = 1e-9))
  disk <- local_problem(lib, toy$field, rho_x = rho$rho_x, rho_t = rho$rho_t,
                        prior = list(shape = 1e-9, rate = 1e-9))
  expect_identical(disk$C, mem$C)
  expect_identical(posterior_exact(lib, toy$field, rho$rho_x, rho$rho_t)$joint,
                   posterior_exact(toy$library, toy$field, rho$rho_x, rho$rho_t)$joint)
  for (u in c("collapsed", "thesis")) {
    a <- suppressWarnings(
      calibrate(toy$library, toy$field, rho$rho_x, rho$rho_t, n_iter = 600, burn_in = 100,
                update = u, seed = 3),
      classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
    b <- suppressWarnings(
      calibrate(lib, toy$field, rho$rho_x, rho$rho_t, n_iter = 600, burn_in = 100,
                update = u, seed = 3),
      classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
    expect_identical(b$draws, a$draws)
  }
  # summaries and predictions read the drawn runs from the chunks
  expect_identical(summary(b)$mean, summary(a)$mean)
  expect_identical(predict(b, seed = 1), predict(a, seed = 1))
  expect_identical(lib_outputs(lib, c(81L, 1L, 21L, 20L, 21L)),
                   toy$library$y[c(81, 1, 21, 20, 21), ])
  expect_error(disk_library(file.path(dir, "nowhere")), "holds no library",
               class = "griddy_error_library")
})

test_that("write_library_chunks() is defunct and points to write_library()", {
  toy <- toy_ar1(n_runs = 10, n_t = 5)
  expect_error(write_library_chunks(toy$library, tempfile()), "write_library\\(library, file")
  expect_error(write_library_chunks(), class = "defunctError")
})

test_that("finding (a): an append that died between theta.rds and manifest.rds is detected and repaired", {
  toy <- toy_ar1(n_runs = 50, n_t = 10)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(lib_rows(toy$library, 1:30), dir, chunk_size = 16)
  # the old writer, killed after theta.rds: 50 theta rows, chunks for 30
  write_rds_chunks(lib_rows(toy$library, 31:50), dir, chunk_size = 16, append = TRUE,
                   die_after = "theta")
  expect_error(disk_library(dir, trust = TRUE), class = "griddy_error_library")
  expect_error(disk_library(dir, trust = TRUE), paste0(
    "theta.rds has 50 runs but the chunks listed in manifest.rds hold 30.*",
    "repair_library\\(.*cut theta.rds back to the 30 runs"))
  expect_message(res <- repair_library(dir, trust = TRUE), "holds 30 runs; 20 uncommitted run\\(s\\) discarded")
  expect_identical(res$removed_files, c("chunk-000003.rds", "chunk-000004.rds"))
  lib <- disk_library(dir, trust = TRUE)
  expect_identical(lib_outputs(lib), toy$library$y[1:30, ])
  expect_identical(as.matrix(lib$theta), as.matrix(toy$library$theta[1:30, , drop = FALSE]))
  # the repaired directory converts to HDF5, where appends are safe
  skip_if_not_installed("hdf5r")
  file <- withr::local_tempfile(fileext = ".h5")
  write_library(lib, file, chunk_size = 7)
  h5 <- write_library(lib_rows(toy$library, 31:50), file, append = TRUE)
  expect_identical(lib_outputs(h5), toy$library$y)
  expect_identical(posterior_exact(h5, toy$field)$joint,
                   posterior_exact(toy$library, toy$field)$joint)
  # fewer theta rows than chunk rows is no interrupted append: not repairable
  saveRDS(toy$library$theta[1:20, , drop = FALSE], file.path(dir, "theta.rds"))
  expect_error(disk_library(dir, trust = TRUE), "cannot be repaired", class = "griddy_error_library")
  expect_error(repair_library(dir, trust = TRUE), "cannot be repaired", class = "griddy_error_library")
})

test_that("finding (c): a chunk with the wrong dimensions stops with the file's name", {
  toy <- toy_ar1(n_runs = 50, n_t = 10)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(toy$library, dir, chunk_size = 16)
  chunk2 <- file.path(dir, "chunk-000002.rds")
  y2 <- readRDS(chunk2)
  # fewer columns than the manifest's n_out
  saveRDS(y2[, 1:9], chunk2)
  lib <- disk_library(dir, trust = TRUE)
  expect_error(posterior_exact(lib, toy$field),
               "chunk-000002.rds holds 16 x 9 \\(runs x outputs\\) where the library expects 16 x 10",
               class = "griddy_error_library")
  expect_error(calibrate(lib, toy$field, n_iter = 100, burn_in = 10, seed = 1),
               class = "griddy_error_library")
  expect_error(lib_outputs(lib, 20), "chunk-000002.rds holds 16 x 9")
  # a short chunk (would be recycled)
  saveRDS(y2[1:5, ], chunk2)
  expect_error(posterior_exact(lib, toy$field), "chunk-000002.rds holds 5 x 10",
               class = "griddy_error_library")
  # non-finite outputs and the wrong type
  y2[3, 4] <- NaN
  saveRDS(y2, chunk2)
  expect_error(posterior_exact(lib, toy$field), "chunk-000002.rds holds non-finite outputs \\(NaN\\) at run\\(s\\) 19",
               class = "griddy_error_library")
  saveRDS(as.data.frame(y2), chunk2)
  expect_error(posterior_exact(lib, toy$field), "should hold a numeric runs x outputs matrix",
               class = "griddy_error_library")
})

test_that("finding (d): a missing or corrupt chunk is griddy's error, not readRDS's", {
  toy <- toy_ar1(n_runs = 50, n_t = 10)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(toy$library, dir, chunk_size = 16)
  lib <- disk_library(dir, trust = TRUE)
  chunk3 <- file.path(dir, "chunk-000003.rds")
  writeBin(readBin(chunk3, "raw", 100), chunk3) # truncated
  err <- expect_error(posterior_exact(lib, toy$field), class = "griddy_error_library")
  expect_match(conditionMessage(err), "chunk-000003.rds cannot be read: it is corrupt or truncated")
  expect_no_match(conditionMessage(err), "^Error in readRDS")
  unlink(chunk3)
  expect_error(posterior_exact(lib, toy$field), "chunk-000003.rds is missing",
               class = "griddy_error_library")
  expect_error(disk_library(dir, trust = TRUE), "lacks chunk file\\(s\\) chunk-000003.rds",
               class = "griddy_error_library")
  writeLines("not an rds file", file.path(dir, "manifest.rds"))
  expect_error(disk_library(dir, trust = TRUE), "manifest.rds cannot be read", class = "griddy_error_library")
})

test_that("an edited disk_library is a shape error before any C++", {
  toy <- toy_ar1(n_runs = 50, n_t = 10)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(toy$library, dir, chunk_size = 16)
  lib <- disk_library(dir, trust = TRUE)
  bad <- lib
  bad$theta$theta[4] <- NA
  expect_error(posterior_exact(bad, toy$field), "has been edited.*NA at \\[4, theta\\]",
               class = "griddy_error_shape")
  bad <- lib
  bad$theta <- bad$theta[-1, , drop = FALSE]
  expect_error(calibrate(bad, toy$field, n_iter = 100, burn_in = 10),
               "`theta` has 49 rows but the library holds 50 runs", class = "griddy_error_shape")
  bad <- lib
  bad$rows <- bad$rows[-1]
  expect_error(posterior_exact(bad, toy$field), "`files` and `rows`", class = "griddy_error_shape")
  bad <- lib
  bad$t <- bad$t[-1]
  expect_error(check_library(bad), "x and t give 1 x 9 = 9 outputs per run but the library holds 10",
               class = "griddy_error_shape")
})

test_that("chunks mapped on two future workers give the same C", {
  skip_on_cran()
  skip_if_not_installed("future.apply")
  skip_if_not(installed_griddy_is_current("chunked_quad_forms"),
              "the installed griddy is not this version")
  toy <- toy_xt(n_per_dim = 6)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(toy$library, dir, chunk_size = 10)
  lib <- disk_library(dir, trust = TRUE)
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

test_that("a corrupt chunk leaves no connection open", {
  # found on a fresh machine: future (CRAN's newest) warned that reading a
  # corrupt chunk left a gzfile connection open
  dir <- withr::local_tempdir()
  saveRDS(matrix(1, 2, 2), file.path(dir, "chunk.rds"))
  writeBin(as.raw(c(0x1f, 0x8b, 0x08, 0x00, 1:20)), file.path(dir, "chunk.rds"))
  before <- nrow(showConnections(all = TRUE))
  expect_error(read_rds_checked(file.path(dir, "chunk.rds"), "Chunk"), class = "griddy_error_library")
  expect_identical(nrow(showConnections(all = TRUE)), before)
  expect_error(read_rds_checked(file.path(dir, "missing.rds"), "Chunk"), "is missing",
               class = "griddy_error_library")
  expect_identical(nrow(showConnections(all = TRUE)), before)
})

test_that("a chunked library gives the in-memory C with missing data, sd and noise groups", {
  toy <- toy_xt(n_per_dim = 5)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(toy$library, dir, chunk_size = 7)
  lib <- disk_library(dir, trust = TRUE)
  y <- toy$field$y
  y[2, 3:7] <- NA
  field <- field_data(y, x = toy$field$x, t = toy$field$t, sd = seq(1, 2, length.out = 12))
  prior <- list(shape = 1, rate = 0.1)
  mem <- local_problem(toy$library, field, rho_x = c(0, 0.3), rho_t = c(0, 0.5), prior = prior,
                       noise_groups = "x")
  disk <- local_problem(lib, field, rho_x = c(0, 0.3), rho_t = c(0, 0.5), prior = prior,
                        noise_groups = "x")
  expect_false(is.null(mem$setup$dense))
  expect_equal(disk$C, mem$C)
})

test_that("an .rds directory is read only with trust = TRUE: reading .rds can run code (CVE-2024-27322)", {
  toy <- toy_ar1(n_runs = 12, n_t = 4)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(toy$library, dir, chunk_size = 5)
  # refused before any file is deserialised: a theta.rds that would fail to
  # read shows it was never opened
  saveRDS(toy$library$theta, file.path(dir, "theta.rds"))
  writeBin(as.raw(1:20), file.path(dir, "manifest.rds"))
  err <- expect_error(disk_library(dir), class = "griddy_error_untrusted")
  expect_match(conditionMessage(err), "CVE-2024-27322.*trust = TRUE.*write_library")
  expect_error(disk_library(dir, trust = NA), "`trust` must be TRUE or FALSE")
  expect_error(repair_library(dir), class = "griddy_error_untrusted")
  # the opt-in reads it (and here finds the damaged manifest)
  expect_error(disk_library(dir, trust = TRUE), "manifest.rds cannot be read",
               class = "griddy_error_library")
  write_rds_chunks(toy$library, dir2 <- withr::local_tempfile(pattern = "griddy-lib-"),
                   chunk_size = 5)
  expect_identical(lib_outputs(disk_library(dir2, trust = TRUE)), toy$library$y)
})

test_that("an .rds directory of 1 run is a classed error (issue 22)", {
  toy <- toy_ar1(n_runs = 10, n_t = 3)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  dir.create(dir)
  saveRDS(toy$library$y[1, , drop = FALSE], file.path(dir, "chunk-000001.rds"))
  saveRDS(toy$library$theta[1, , drop = FALSE], file.path(dir, "theta.rds"))
  saveRDS(list(x = NULL, t = toy$library$t, theta_names = names(toy$library$theta), n_out = 3L,
               files = "chunk-000001.rds", rows = 1L), file.path(dir, "manifest.rds"))
  expect_error(disk_library(dir, trust = TRUE), "holds 1 run",
               class = "griddy_error_library_size")
})

test_that("print.disk_library() shows the runs and the chunks", {
  toy <- toy_xt(n_per_dim = 4)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(toy$library, dir, chunk_size = 10)
  expect_snapshot(print(disk_library(dir, trust = TRUE)), transform = scrub_print)
})
