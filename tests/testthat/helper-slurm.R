# A single-node Slurm for the tests that submit jobs: started by
# tools/slurm-start.sh when it is not running and we are root (its daemons
# stopped by tools/slurm-stop.sh when the test run ends), or the test is
# skipped with the reason. Jobs load griddy from the library (R_LIBS is
# passed on by Slurm), so the installed griddy must be this version.
slurm_session <- new.env(parent = emptyenv())

local_slurm <- function(env = parent.frame()) {
  skip_on_cran()
  skip_if_not_installed("future.batchtools")
  skip_if_not_installed("hdf5r")
  tools <- normalizePath(test_path("..", "..", "tools"), mustWork = FALSE)
  start <- file.path(tools, "slurm-start.sh")
  if (!file.exists(start)) skip("tools/slurm-start.sh is not here (not a source tree)")
  skip_if_not(installed_griddy_is_current("run_chunks"),
              "Slurm jobs load the installed griddy, which is not this version")
  # started once per test run, stopped when the run ends (a restart between
  # tests would leave the scheduler recovering the last test's jobs)
  if (is.null(slurm_session$status)) {
    state <- tempfile("slurm-state")
    out <- suppressWarnings(system2("bash", start, stdout = TRUE, stderr = TRUE,
                                    env = paste0("GRIDDY_SLURM_STATE=", state)))
    slurm_session$status <- if (is.null(attr(out, "status"))) 0L else attr(out, "status")
    slurm_session$out <- out
    withr::defer(system2("bash", file.path(tools, "slurm-stop.sh"),
                         env = paste0("GRIDDY_SLURM_STATE=", state)),
                 envir = testthat::teardown_env())
  }
  if (slurm_session$status != 0L) {
    skip(paste("Slurm cannot start here:", paste(slurm_session$out, collapse = " ")))
  }
  # the jobs' registries where the jobs see them (one machine: tempdir())
  withr::local_options(future.cache.path = file.path(tempdir(), "future"), .local_envir = env)
  template <- test_path("..", "..", "inst", "templates", "batchtools.slurm.tmpl")
  if (!file.exists(template)) {
    template <- system.file("templates", "batchtools.slurm.tmpl", package = "griddy")
  }
  template
}

# Cancels the Slurm jobs of griddy's simulator chunks still queued or
# running (left by a writer that was killed), and no others: they carry the
# job name of their futures' label.
cancel_simulator_jobs <- function() {
  system2("scancel", c("--name", "griddy-simulator"), stdout = FALSE, stderr = FALSE)
}
