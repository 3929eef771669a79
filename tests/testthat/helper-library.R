# Libraries on disk for the tests: the old .rds chunk format, as the retired
# write_library_chunks() wrote it (in its order: chunks, theta.rds, then
# manifest.rds), and HDF5 files as a user's own pipeline would write them.

write_rds_chunks <- function(library, dir, chunk_size = 1e5, append = FALSE,
                             die_after = NULL) {
  manifest_file <- file.path(dir, "manifest.rds")
  if (append) {
    old <- readRDS(manifest_file)
    theta <- rbind(readRDS(file.path(dir, "theta.rds")), library$theta)
  } else {
    dir.create(dir, recursive = TRUE, showWarnings = FALSE)
    old <- list(x = library$x, t = library$t, theta_names = names(library$theta),
                n_out = ncol(library$y), files = character(0), rows = integer(0))
    theta <- library$theta
  }
  n <- nrow(library$y)
  starts <- seq(1L, n, by = chunk_size)
  files <- sprintf("chunk-%06d.rds", length(old$files) + seq_along(starts))
  rows <- integer(length(starts))
  for (k in seq_along(starts)) {
    idx <- starts[k]:min(n, starts[k] + chunk_size - 1L)
    saveRDS(library$y[idx, , drop = FALSE], file.path(dir, files[k]))
    rows[k] <- length(idx)
  }
  saveRDS(theta, file.path(dir, "theta.rds"))
  if (identical(die_after, "theta")) return(invisible(NULL))
  old$files <- c(old$files, files)
  old$rows <- c(old$rows, rows)
  saveRDS(old, manifest_file)
  invisible(dir)
}

# An HDF5 file as another pipeline writes it. `layout` is the outputs'
# orientation in HDF5's order: "runs_first" as h5py writes a runs x outputs
# array (R sees it transposed), "runs_last" as R writes an N x n matrix.
# `theta_as`: "compound" (a data.frame), "matrix" (numeric, names in an
# attribute, oriented as `layout`) or "bare" (numeric, no names).
write_user_h5 <- function(library, file, layout = "runs_first", theta_as = "compound",
                          with_t = TRUE) {
  h5 <- hdf5r::H5File$new(file, "w")
  on.exit(h5$close_all())
  th <- as.matrix(library$theta)
  if (theta_as == "compound") {
    h5[["params"]] <- library$theta
  } else {
    h5[["params"]] <- if (layout == "runs_first") t(th) else unname(th)
    if (theta_as == "matrix") hdf5r::h5attr(h5[["params"]], "names") <- colnames(th)
  }
  h5$create_group("sim")
  h5[["sim/out"]] <- if (layout == "runs_first") t(library$y) else library$y
  if (with_t) h5[["sim/time"]] <- library$t
  invisible(file)
}

# Runs R code in a separate Rscript process with this griddy loaded (from
# the source tree under devtools/testthat, else the installed package).
# Returns the system2() result (the exit status when waiting).
run_child <- function(code, wait = TRUE, stdout = FALSE, stderr = FALSE) {
  system2(file.path(R.home("bin"), "Rscript"), child_script(code), wait = wait,
          stdout = stdout, stderr = stderr)
}

# A script file that loads this griddy, then runs `code`.
child_script <- function(code) {
  path <- getNamespaceInfo("griddy", "path")
  dev <- requireNamespace("pkgload", quietly = TRUE) && pkgload::is_dev_package("griddy")
  prelude <- if (dev) {
    sprintf("suppressMessages(pkgload::load_all(%s, quiet = TRUE, export_all = FALSE))",
            deparse(path))
  } else {
    "suppressMessages(library(griddy))"
  }
  script <- tempfile(fileext = ".R")
  writeLines(c(prelude, code), script)
  script
}

# Waits until `file` exists (a child's signal), at most `timeout` seconds.
wait_for_file <- function(file, timeout = 60) {
  start <- Sys.time()
  while (!file.exists(file)) {
    if (as.numeric(difftime(Sys.time(), start, units = "secs")) > timeout) {
      stop("timed out waiting for ", file)
    }
    Sys.sleep(0.05)
  }
  invisible(TRUE)
}

# A sim_library of some rows of another.
lib_rows <- function(library, rows) {
  sim_library(library$theta[rows, , drop = FALSE], library$y[rows, , drop = FALSE],
              x = library$x, t = library$t)
}

# A toy fit whose coarse library the test is not about: its resolution
# warning muffled, every other warning kept.
without_resolution_warning <- function(expr) {
  suppressWarnings(expr, classes = "griddy_warning_resolution")
}
