test_that("a library on disk gives the in-memory C, exact posterior and draws", {
  toy <- toy_xt(n_per_dim = 9)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  lib <- write_library_chunks(toy$library, dir, chunk_size = 20)
  expect_s3_class(lib, "disk_library")
  expect_length(lib$files, 5)
  expect_identical(lib$rows, c(20L, 20L, 20L, 20L, 1L))
  expect_output(print(lib), "81 runs of 2 parameter\\(s\\) in 5 chunk\\(s\\)")
  rho <- list(rho_x = c(0, 0.3), rho_t = c(0, 0.5))
  mem <- calibration_problem(toy$library, toy$field, rho$rho_x, rho$rho_t,
                             list(shape = 1e-9, rate = 1e-9), 2, NULL)
  disk <- calibration_problem(lib, toy$field, rho$rho_x, rho$rho_t,
                              list(shape = 1e-9, rate = 1e-9), 2, NULL)
  expect_identical(disk$C, mem$C)
  expect_identical(posterior_exact(lib, toy$field, rho$rho_x, rho$rho_t)$joint,
                   posterior_exact(toy$library, toy$field, rho$rho_x, rho$rho_t)$joint)
  for (u in c("collapsed", "thesis")) {
    a <- calibrate(toy$library, toy$field, rho$rho_x, rho$rho_t, n_iter = 600, burn_in = 100,
                   update = u, seed = 3)
    b <- calibrate(lib, toy$field, rho$rho_x, rho$rho_t, n_iter = 600, burn_in = 100,
                   update = u, seed = 3)
    expect_identical(b$draws, a$draws)
  }
  # summaries and predictions read the drawn runs from the chunks
  expect_identical(summary(b)$mean, summary(a)$mean)
  expect_identical(predict(b, seed = 1), predict(a, seed = 1))
})

test_that("libraries can be written piece by piece", {
  toy <- toy_ar1(n_runs = 50, n_t = 10)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  lib <- toy$library
  piece <- function(rows) sim_library(lib$theta[rows, , drop = FALSE], lib$y[rows, ], t = lib$t)
  write_library_chunks(piece(1:30), dir, chunk_size = 16)
  expect_error(write_library_chunks(piece(31:50), dir), "already holds a library")
  expect_error(write_library_chunks(piece(21:40), dir, append = TRUE), "duplicated runs")
  disk <- write_library_chunks(piece(31:50), dir, chunk_size = 16, append = TRUE)
  expect_identical(disk$rows, c(16L, 14L, 16L, 4L))
  expect_identical(lib_outputs(disk, c(50L, 1L, 17L, 31L, 17L)), lib$y[c(50, 1, 17, 31, 17), ])
  expect_identical(posterior_exact(disk, toy$field)$run, posterior_exact(lib, toy$field)$run)
  other <- sim_library(data.frame(theta = c(2, 3)), lib$y[1:2, ], t = lib$t + 1)
  expect_error(write_library_chunks(other, dir, append = TRUE), "must have the parameters")
  expect_error(disk_library(file.path(dir, "nowhere")), "holds no library")
  expect_error(write_library_chunks(lib, 3), "`dir` must be a single non-empty string")
  expect_error(write_library_chunks(disk, dir), "must be a sim_library")
})

test_that("chunks mapped on two future workers give the same C", {
  skip_on_cran()
  skip_if_not_installed("future.apply")
  skip_if_not(installed_griddy_is_current("disk_quad_forms"),
              "the installed griddy is not this version")
  toy <- toy_xt(n_per_dim = 6)
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  lib <- write_library_chunks(toy$library, dir, chunk_size = 10)
  serial <- posterior_exact(lib, toy$field, rho_t = c(0, 0.5))
  old <- future::plan(future::multisession, workers = 2)
  on.exit(future::plan(old), add = TRUE)
  expect_identical(posterior_exact(lib, toy$field, rho_t = c(0, 0.5))$joint, serial$joint)
  a <- calibrate(lib, toy$field, rho_t = c(0, 0.5), n_iter = 400, burn_in = 100, seed = 2)
  future::plan(future::sequential)
  b <- calibrate(lib, toy$field, rho_t = c(0, 0.5), n_iter = 400, burn_in = 100, seed = 2)
  expect_identical(a$draws, b$draws)
})
