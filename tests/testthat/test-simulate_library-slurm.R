# simulate_library() and refine() on a real scheduler: a single-node Slurm
# (see helper-slurm.R), reached through future.batchtools and the template
# griddy ships, as a user's own cluster would be.

test_that("a campaign on Slurm survives a cancelled job and a killed writer with nothing lost", {
  template <- local_slurm()
  design <- design_lhs(10, k = c(1, 4), c = c(0, 1), seed = 6)
  dir <- withr::local_tempdir()
  file <- file.path(dir, "campaign.h5")
  marker <- file.path(dir, "cancelled")
  pid_file <- file.path(dir, "writer.pid")
  saveRDS(design, file.path(dir, "design.rds"))
  # the simulator of design row 3 cancels its own Slurm job (scancel) the
  # first time it runs: the run is lost with its job and run again
  victim <- design$k[3]
  campaign <- c(
    sprintf("writeLines(as.character(Sys.getpid()), %s)", deparse(pid_file)),
    sprintf("options(future.cache.path = %s)", deparse(file.path(dir, "future"))),
    sprintf("future::plan(future.batchtools::batchtools_slurm, template = %s, workers = 2)",
            deparse(normalizePath(template))),
    "sim <- function(theta, marker, victim) {",
    "  if (victim %in% theta$k && !file.exists(marker)) {",
    "    file.create(marker)",
    "    system(paste('scancel', Sys.getenv('SLURM_JOB_ID')))",
    "    Sys.sleep(60)",
    "  }",
    "  Sys.sleep(1)",
    "  t <- seq(0, 1, length.out = 20)",
    "  t(mapply(function(k, c) sin(k * t) + c, theta$k, theta$c))",
    "}",
    sprintf("design <- readRDS(%s)", deparse(file.path(dir, "design.rds"))),
    sprintf("simulate_library(sim, design, %s, t = seq(0, 1, length.out = 20),",
            deparse(file)),
    sprintf("                 marker = %s, victim = design$k[3], progress = FALSE)",
            deparse(marker)))
  # the writer runs in its own R process, killed (SIGKILL) once some runs
  # are committed, as a lost session would be
  writer_log <- file.path(dir, "writer.log")
  run_child(campaign, wait = FALSE, stdout = writer_log, stderr = writer_log)
  log <- function() paste(c("", "the writer's output:", readLines(writer_log)), collapse = "\n")
  wait_for_file(pid_file)
  pid <- as.integer(readLines(pid_file))
  withr::defer(tools::pskill(pid, tools::SIGKILL))
  # while the writer lives, its lock means an append may be under way; once
  # it is killed (perhaps mid-append, leaving its lock), the committed runs
  # are read whatever the lock (a lock left behind made this count 0 in 2
  # of 4 runs on a loaded machine, though the file held 4 committed runs)
  committed <- function(writer_alive = TRUE) {
    if (!file.exists(file)) return(0L)
    if (writer_alive && dir.exists(paste0(file, ".lock"))) return(0L)
    tryCatch(nrow(h5_committed_theta(file)$theta), error = function(e) 0L)
  }
  slurm_jobs <- function() {
    suppressWarnings(system2("squeue", c("-h", "--name", "griddy-simulator", "-o", "%i"),
                             stdout = TRUE, stderr = FALSE))
  }
  seen_jobs <- character(0)
  start <- Sys.time()
  while ((committed() < 4L || !file.exists(marker)) &&
         difftime(Sys.time(), start, units = "secs") < 120) {
    seen_jobs <- union(seen_jobs, slurm_jobs())
    Sys.sleep(0.2)
  }
  expect_gte(length(seen_jobs), 2L)  # the runs were Slurm jobs
  tools::pskill(pid, tools::SIGKILL)
  Sys.sleep(0.5)
  n_before <- committed(writer_alive = FALSE)
  expect_gte(n_before, 4L, label = paste0("runs committed (", n_before, ")", log()))
  expect_lt(n_before, nrow(design))  # killed midway: the rerun has runs to do
  expect_true(file.exists(marker))  # the victim's job was cancelled
  # the jobs the killed writer left are cancelled, as a user would
  cancel_simulator_jobs()

  # resumed in this session (in this process: what is resumed does not
  # depend on where the runs are made, and a second set of Slurm jobs would
  # double the test's time)
  sim <- function(theta) {
    t <- seq(0, 1, length.out = 20)
    t(mapply(function(k, c) sin(k * t) + c, theta$k, theta$c))
  }
  environment(sim) <- globalenv()
  lib <- simulate_library(sim, design, file, t = campaign_t, progress = FALSE)
  expect_equal(nrow(attr(lib, "failed")), 0L,
               info = paste(substr(attr(lib, "failed")$message, 1, 1000), collapse = "\n"))
  expect_complete_campaign(lib, design)
  expect_true(victim %in% as.data.frame(lib)$k)
})

test_that("refine(file =) on Slurm keeps every run of its rounds in the file", {
  template <- local_slurm()
  toy <- refine_toy()
  file <- file.path(withr::local_tempdir(), "refine.h5")
  future::plan(future.batchtools::batchtools_slurm, template = template, workers = 2)
  withr::defer(future::plan("sequential"))
  sim <- refine_sim
  environment(sim) <- globalenv()
  ref <- suppressWarnings(refine(toy$fit, sim, max_runs = 4, runs_per_round = 4, file = file,
                                 seed = 1, progress = FALSE))
  on_disk <- hdf5_library(file)
  added <- lib_theta(ref$library)$k[-seq_len(lib_n_runs(toy$lib))]
  expect_length(added, 4L)
  expect_setequal(lib_theta(on_disk)$k, added)
  expect_equal(lib_outputs(on_disk), refine_sim(lib_theta(on_disk)))
})
