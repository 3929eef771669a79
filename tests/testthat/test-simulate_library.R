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
  # nothing left to do: the simulator is not called, also with the design
  # written to CSV and read back (15 digits, not the same bits)
  s3 <- campaign_sim()
  lib <- simulate_library(s3$sim, design[c("c", "k")], file, t = campaign_t)
  csv <- withr::local_tempfile(fileext = ".csv")
  utils::write.csv(design, csv, row.names = FALSE)
  lib <- simulate_library(s3$sim, utils::read.csv(csv), file, t = campaign_t)
  data.table::fwrite(design, csv)
  lib <- simulate_library(s3$sim, data.table::fread(csv), file, t = campaign_t)
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

test_that("a simulator condition without a message fails its rows like any error", {
  skip_if_not_installed("hdf5r")
  design <- design_grid(k = c(1, 2, 3), c = c(0, 1))
  file <- withr::local_tempfile(fileext = ".h5")
  sim <- function(theta) {
    if (any(theta$k == 2)) {
      stop(structure(class = c("myerr", "error", "condition"), list(message = NULL, call = NULL)))
    }
    campaign_outputs(theta)
  }
  expect_warning(lib <- simulate_library(sim, design, file, t = campaign_t, progress = FALSE),
                 "design row 2 .*myerr", class = "griddy_warning_simulation_failed")
  expect_equal(attr(lib, "failed")$row, c(2L, 5L))
  expect_match(attr(lib, "failed")$message, "class myerr/error/condition with no message")
  expect_equal(lib$n_runs, 4L)
})

test_that("a writer killed midway loses only the runs in flight; the rerun completes the design", {
  skip_if_not_installed("hdf5r")
  skip_on_cran()
  design <- design_lhs(100, k = c(1, 4), c = c(0, 1), seed = 3)
  file <- withr::local_tempfile(fileext = ".h5")
  design_file <- withr::local_tempfile(fileext = ".rds")
  pid_file <- withr::local_tempfile()
  saveRDS(design, design_file)  # the same bits: rows are matched by their values
  # 10 chunks of 10 runs, 0.02 s a run: the writer is killed after a commit
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
  while (committed() < 20L && difftime(Sys.time(), start, units = "secs") < 60) {
    Sys.sleep(0.05)
  }
  tools::pskill(pid, tools::SIGKILL)
  Sys.sleep(0.2)
  done_before <- committed()
  expect_gte(done_before, 20L)
  expect_lt(done_before, 100L)
  s <- campaign_sim()
  lib <- simulate_library(s$sim, design, file, t = campaign_t)
  expect_length(s$seen, 100L - done_before)
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

test_that("on two workers: globals found, a lost worker's runs rerun, the culprit failed, plan whole", {
  skip_if_not_installed("hdf5r")
  skip_if_not_installed("future.apply")
  skip_on_cran()
  design <- design_lhs(20, k = c(1, 4), c = c(0, 1), seed = 4)
  dir <- withr::local_tempdir()
  # a simulator as a user writes it: in the global environment, reading
  # global variables (which future sends to the workers); on a worker, the
  # run of design row 5 kills its worker (the culprit), losing the other run
  # of its chunk (row 6) with it
  globals <- list(griddy_test_main = Sys.getpid(), griddy_test_amp = 2,
                  griddy_test_t = campaign_t, griddy_test_culprit = design$k[5])
  list2env(globals, globalenv())
  withr::defer(rm(list = names(globals), envir = globalenv()))
  sim <- function(theta) {
    if (Sys.getpid() != griddy_test_main && griddy_test_culprit %in% theta$k) {
      tools::pskill(Sys.getpid(), tools::SIGKILL)
    }
    if (any(theta$k > 3.9)) stop("too stiff")
    t(mapply(function(k, c) griddy_test_amp * sin(k * griddy_test_t) + c, theta$k, theta$c))
  }
  environment(sim) <- globalenv()
  sequential <- suppressWarnings(simulate_library(sim, design, file.path(dir, "seq.h5"),
                                                  t = campaign_t, progress = FALSE))
  future::plan("multisession", workers = 2)
  withr::defer(future::plan("sequential"))
  w <- NULL
  parallel <- withCallingHandlers(
    simulate_library(sim, design, file.path(dir, "par.h5"), t = campaign_t, progress = FALSE),
    griddy_warning_simulation_failed = function(cnd) {
      w <<- cnd
      invokeRestart("muffleWarning")
    })
  expect_true(design$k[6] %in% as.data.frame(parallel)$k)
  # every run but the culprit's, as the sequential campaign made them
  failed <- attr(parallel, "failed")
  stiff <- attr(sequential, "failed")$row
  expect_setequal(failed$row, c(5L, stiff))
  expect_match(failed$message[failed$row == 5L], "no longer alive|worker|connection")
  expect_match(conditionMessage(w), "design row 5 ", fixed = TRUE)
  keep <- as.data.frame(sequential)$k != design$k[5]
  key <- function(lib) order(as.data.frame(lib)$k)
  expect_equal(as.data.frame(parallel)[key(parallel), , drop = FALSE],
               as.data.frame(sequential)[key(sequential), , drop = FALSE][keep[key(sequential)], ,
                                                                          drop = FALSE],
               ignore_attr = TRUE)
  expect_equal(as.matrix(parallel)[key(parallel), ],
               as.matrix(sequential)[key(sequential), ][keep[key(sequential)], ])
  # the plan is whole: both workers take futures
  pids <- vapply(1:4, function(i) future::value(future::future(Sys.getpid())), numeric(1))
  expect_false(any(pids == Sys.getpid()))
})
