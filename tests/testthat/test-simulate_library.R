test_that("a campaign commits every design row once and resumes without simulating any again", {
  skip_if_not_installed("hdf5r")
  design <- design_lhs(30, k = c(1, 4), c = c(0, 1), seed = 1)
  file <- withr::local_tempfile(fileext = ".h5")
  s <- campaign_sim()
  lib <- simulate_library(s$sim, design[1:20, ], file, t = campaign_t, seed = 1)
  expect_s3_class(lib, "hdf5_library")
  expect_complete_campaign(lib, design[1:20, ])
  expect_equal(nrow(attr(lib, "failed")), 0L)
  # the whole design on the same file: only the 10 new rows are simulated
  s2 <- campaign_sim()
  lib <- simulate_library(s2$sim, design, file, t = campaign_t, seed = 1)
  expect_setequal(s2$seen, design$k[21:30])
  expect_complete_campaign(lib, design)
  # nothing left to do: the simulator is not called
  s3 <- campaign_sim()
  lib <- simulate_library(s3$sim, design[c("c", "k")], file, t = campaign_t)
  expect_length(s3$seen, 0L)
  expect_equal(lib$n_runs, 30L)
})

test_that("failing rows are retried alone, named in a classed warning, recorded, and run by the next call", {
  skip_if_not_installed("hdf5r")
  design <- design_lhs(40, k = c(1, 4), c = c(0, 1), seed = 2)
  file <- withr::local_tempfile(fileext = ".h5")
  bad <- c(3L, 17L, 31L)
  s <- campaign_sim(broken = design$k[bad])
  w <- NULL
  lib <- withCallingHandlers(
    simulate_library(s$sim, design, file, t = campaign_t),
    griddy_warning_simulation_failed = function(cnd) {
      w <<- cnd
      invokeRestart("muffleWarning")
    })
  expect_s3_class(w, "griddy_warning_simulation_failed")
  for (r in bad) expect_match(conditionMessage(w), paste0("design row ", r, " "), fixed = TRUE)
  expect_match(conditionMessage(w), "the mesh did not converge")
  # the other rows of the failing chunks were kept
  expect_equal(lib$n_runs, 37L)
  expect_false(any(design$k[bad] %in% as.data.frame(lib)$k))
  failed <- attr(lib, "failed")
  expect_equal(sort(failed$row), bad)
  expect_equal(failed$k[order(failed$row)], design$k[bad])
  h5 <- hdf5r::H5File$new(file, "r")
  recorded <- h5[["failed"]]$read()
  h5$close_all()
  expect_equal(sort(recorded$row), bad)
  expect_match(recorded$message, "the mesh did not converge")
  # fixed: the next call runs the three rows only, and the record is cleared
  s2 <- campaign_sim()
  lib <- expect_silent(simulate_library(s2$sim, design, file, t = campaign_t,
                                        progress = FALSE))
  expect_setequal(s2$seen, design$k[bad])
  expect_complete_campaign(lib, design)
  h5 <- hdf5r::H5File$new(file, "r")
  expect_false(h5$exists("failed"))
  h5$close_all()
})

test_that("a writer killed midway loses only the runs in flight; the rerun completes the design", {
  skip_if_not_installed("hdf5r")
  skip_on_cran()
  design <- design_lhs(200, k = c(1, 4), c = c(0, 1), seed = 3)
  file <- withr::local_tempfile(fileext = ".h5")
  design_file <- withr::local_tempfile(fileext = ".rds")
  pid_file <- withr::local_tempfile()
  saveRDS(design, design_file)  # the same bits: rows are matched by their values
  # 10 chunks of 20 runs, 0.02 s a run: the writer is killed after a commit
  run_child(c(
    sprintf("writeLines(as.character(Sys.getpid()), %s)", deparse(pid_file)),
    sprintf("design <- readRDS(%s)", deparse(design_file)),
    "t <- seq(0, 1, length.out = 20)",
    "sim <- function(theta) { Sys.sleep(0.02 * nrow(theta))",
    "  t(mapply(function(k, c) sin(k * t) + c, theta$k, theta$c)) }",
    sprintf("simulate_library(sim, design, %s, t = t)", deparse(file))), wait = FALSE)
  wait_for_file(pid_file)
  pid <- as.integer(readLines(pid_file))
  withr::defer(tools::pskill(pid, tools::SIGKILL))
  committed <- function() {
    if (!file.exists(file) || dir.exists(paste0(file, ".lock"))) return(0L)
    n <- tryCatch(nrow(h5_committed_theta(file)$theta), error = function(e) 0L)
    n
  }
  start <- Sys.time()
  while (committed() < 40L && difftime(Sys.time(), start, units = "secs") < 60) {
    Sys.sleep(0.05)
  }
  tools::pskill(pid, tools::SIGKILL)
  Sys.sleep(0.2)
  done_before <- committed()
  expect_gte(done_before, 40L)
  expect_lt(done_before, 200L)
  s <- campaign_sim()
  lib <- simulate_library(s$sim, design, file, t = campaign_t)
  expect_length(s$seen, 200L - done_before)
  expect_complete_campaign(lib, design)
})

test_that("a campaign refuses a broken contract and a file of other parameters", {
  skip_if_not_installed("hdf5r")
  design <- design_grid(k = c(1, 2, 3), c = c(0, 1))
  file <- withr::local_tempfile(fileext = ".h5")
  wrong_shape <- function(theta) campaign_outputs(theta)[, 1:5]
  expect_error(simulate_library(wrong_shape, design, file, t = campaign_t),
               class = "griddy_error_shape")
  expect_error(simulate_library(function(theta) stop("no licence"), design, file),
               "no licence", class = "griddy_error_simulator")
  expect_false(file.exists(file))
  simulate_library(campaign_sim()$sim, design, file, t = campaign_t)
  expect_error(simulate_library(campaign_sim()$sim, data.frame(k = 1:3 + 0.5), file,
                                t = campaign_t), class = "griddy_error_library")
  expect_error(simulate_library("sim", design, file), class = "griddy_error_input")
  expect_error(simulate_library(campaign_sim()$sim, design[c(1, 1), ], file),
               class = "griddy_error_input")
})

test_that("without t, the simulator's first result sets the outputs per run", {
  skip_if_not_installed("hdf5r")
  design <- design_grid(k = c(1, 2, 3), c = c(0, 1))
  file <- withr::local_tempfile(fileext = ".h5")
  lib <- simulate_library(campaign_sim()$sim, design, file, x = data.frame(load = 1:2))
  expect_equal(lib$n_out, 20L)
  expect_equal(lib$t, as.double(1:10))
})

test_that("a campaign on two future workers gives the library of a sequential one", {
  skip_if_not_installed("hdf5r")
  skip_if_not_installed("future.apply")
  skip_on_cran()
  skip_if_not(installed_griddy_is_current("run_chunks"), "the installed griddy is not this version")
  design <- design_lhs(24, k = c(1, 4), c = c(0, 1), seed = 4)
  sim <- function(theta) {
    t <- seq(0, 1, length.out = 20)
    if (any(theta$k > 3.9)) stop("too stiff")
    t(mapply(function(k, c) sin(k * t) + c, theta$k, theta$c))
  }
  environment(sim) <- globalenv()
  seq_file <- withr::local_tempfile(fileext = ".h5")
  par_file <- withr::local_tempfile(fileext = ".h5")
  sequential <- suppressWarnings(simulate_library(sim, design, seq_file, t = campaign_t))
  future::plan("multisession", workers = 2)
  withr::defer(future::plan("sequential"))
  parallel <- suppressWarnings(simulate_library(sim, design, par_file, t = campaign_t))
  keys <- function(lib) order(as.data.frame(lib)$k)
  expect_equal(as.data.frame(parallel)[keys(parallel), , drop = FALSE],
               as.data.frame(sequential)[keys(sequential), , drop = FALSE], ignore_attr = TRUE)
  expect_equal(as.matrix(parallel)[keys(parallel), ], as.matrix(sequential)[keys(sequential), ])
  expect_equal(attr(parallel, "failed"), attr(sequential, "failed"))
})

test_that("a run whose worker is lost (a FutureError) runs again, once", {
  skip_if_not_installed("hdf5r")
  skip_on_cran()
  skip_if_not(installed_griddy_is_current("run_chunks"), "the installed griddy is not this version")
  design <- design_lhs(6, k = c(1, 4), c = c(0, 1), seed = 8)
  dir <- withr::local_tempdir()
  # the run of design row 2 kills its worker the first time (a lost node);
  # that of row 5 kills it every time
  sim <- function(theta, marker, victim, doomed) {
    if (victim %in% theta$k && !file.exists(marker)) {
      file.create(marker)
      tools::pskill(Sys.getpid(), tools::SIGKILL)
    }
    if (doomed %in% theta$k) tools::pskill(Sys.getpid(), tools::SIGKILL)
    t <- seq(0, 1, length.out = 20)
    t(mapply(function(k, c) sin(k * t) + c, theta$k, theta$c))
  }
  environment(sim) <- globalenv()
  future::plan("multisession", workers = 2)
  withr::defer(future::plan("sequential"))
  file <- file.path(dir, "lost.h5")
  expect_warning(
    lib <- simulate_library(sim, design, file, t = campaign_t, marker = file.path(dir, "m"),
                            victim = design$k[2], doomed = design$k[5], progress = FALSE),
    class = "griddy_warning")
  expect_true(file.exists(file.path(dir, "m")))
  expect_true(5L %in% attr(lib, "failed")$row)
  # a dead multisession worker may not be relaunched (future < 1.32), and the
  # runs sent to it fail: they are recorded, and run by the next call on
  # fresh workers
  future::plan("sequential")
  future::plan("multisession", workers = 2)
  lib <- suppressWarnings(simulate_library(
    sim, design, file, t = campaign_t, marker = file.path(dir, "m"),
    victim = design$k[2], doomed = Inf, progress = FALSE))
  expect_equal(nrow(attr(lib, "failed")), 0L)
  expect_complete_campaign(lib, design)
})
