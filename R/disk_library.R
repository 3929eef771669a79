# Libraries stored on disk in chunks, precomputed chunk by chunk so that
# memory holds the runs x grid points table C, never the whole library.

#' Write a simulation library to disk in chunks
#'
#' Stores a [sim_library()] as a directory of chunk files, each holding the
#' outputs of `chunk_size` consecutive runs (R's native `.rds` format), plus the
#' parameter values, the settings and a manifest. With `append = TRUE` the
#' runs are added after those already in `dir`, so a library larger than
#' memory can be written piece by piece as the simulator produces it.
#' [disk_library()] opens the result; [calibrate()] and [posterior_exact()]
#' accept it in place of a `sim_library`.
#'
#' @param library A [sim_library()]: all runs, or the next piece of runs
#'   when `append = TRUE`.
#' @param dir Directory to write to; created if needed. Without `append` it
#'   must not already hold a library.
#' @param chunk_size Runs per chunk file.
#' @param append Add the runs to the library already in `dir` (same
#'   parameters, settings `x` and coordinates `t`).
#' @param compress Compress the chunk files (smaller, slower to read).
#' @return The [disk_library()] in `dir`, invisibly.
#' @seealso [disk_library()]
#' @examples
#' ex <- griddy_example()
#' dir <- file.path(tempdir(), "example-library")
#' lib <- write_library_chunks(ex$library, dir, chunk_size = 100)
#' lib
#' exact <- posterior_exact(lib, ex$field)
#' unlink(dir, recursive = TRUE)
#' @export
write_library_chunks <- function(library, dir, chunk_size = 1e5, append = FALSE,
                                 compress = FALSE) {
  check_library(library, disk = FALSE)
  dir <- assert_string(dir, "dir")
  chunk_size <- assert_count(chunk_size, "chunk_size")
  append <- assert_flag(append, "append")
  compress <- assert_flag(compress, "compress")
  manifest_file <- file.path(dir, "manifest.rds")
  if (append) {
    if (!file.exists(manifest_file)) {
      griddy_abort("`dir` (", dir, ") holds no library to append to: write the first ",
                   "piece with `append = FALSE`.")
    }
    old <- readRDS(manifest_file)
    if (!identical(old$x, library$x) || !identical(old$t, library$t) ||
        !identical(old$theta_names, names(library$theta))) {
      griddy_abort("`library` must have the parameters, settings `x` and coordinates `t` ",
                   "of the library in `dir` to be appended to it.")
    }
    theta <- rbind(readRDS(file.path(dir, "theta.rds")), library$theta)
    assert_distinct_runs(as.matrix(theta))
  } else {
    if (file.exists(manifest_file)) {
      griddy_abort("`dir` (", dir, ") already holds a library; use `append = TRUE` to add ",
                   "runs or choose a new directory.")
    }
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
    saveRDS(library$y[idx, , drop = FALSE], file.path(dir, files[k]), compress = compress)
    rows[k] <- length(idx)
  }
  saveRDS(theta, file.path(dir, "theta.rds"), compress = compress)
  old$files <- c(old$files, files)
  old$rows <- c(old$rows, rows)
  saveRDS(old, manifest_file)
  invisible(disk_library(dir))
}

#' A simulation library stored on disk in chunks
#'
#' Opens a library written by [write_library_chunks()]. Only the parameter
#' values (`N x p`) are read into memory; the outputs stay in the chunk files.
#' [calibrate()] and [posterior_exact()] read the chunks one at a time to
#' compute the quadratic forms \eqn{C_{ig}}, so memory holds the `N x G` table
#' of \eqn{C_{ig}} and one chunk per worker, never the whole library.
#'
#' The chunks are mapped with [future.apply::future_lapply()], so the same
#' call runs sequentially (the default plan), on local cores
#' (`future::plan("multisession")`), or on a cluster or a batch queue through
#' any future backend the user chooses (for example future.batchtools for
#' Slurm), without a change to the calibration code. The workers need griddy
#' installed and must see `dir`. Without future.apply the chunks are read
#' sequentially.
#'
#' @param dir Directory holding the library.
#' @return An object of class `disk_library`: a list with the directory
#'   `dir`, the chunk `files` and their `rows`, the parameter values `theta`
#'   (a data.frame), the settings `x` and coordinates `t`.
#' @seealso [write_library_chunks()], [calibrate()]
#' @examples
#' ex <- griddy_example()
#' dir <- file.path(tempdir(), "example-library-2")
#' write_library_chunks(ex$library, dir, chunk_size = 100)
#' lib <- disk_library(dir)
#' fit <- calibrate(lib, ex$field, n_iter = 1000, burn_in = 200, seed = 1)
#' fit
#' unlink(dir, recursive = TRUE)
#' @export
disk_library <- function(dir) {
  dir <- assert_string(dir, "dir")
  manifest_file <- file.path(dir, "manifest.rds")
  if (!file.exists(manifest_file)) {
    griddy_abort("`dir` (", dir, ") holds no library written by write_library_chunks().")
  }
  m <- readRDS(manifest_file)
  files <- file.path(normalizePath(dir), m$files)
  missing <- !file.exists(files)
  if (any(missing)) {
    griddy_abort("The library in `dir` lacks chunk file(s) ", show_some(m$files[missing]), ".")
  }
  structure(
    list(dir = normalizePath(dir), files = files, rows = m$rows,
         theta = readRDS(file.path(dir, "theta.rds")), x = m$x, t = m$t, n_out = m$n_out),
    class = "disk_library"
  )
}

#' @export
print.disk_library <- function(x, ...) {
  cli::cat_line("<disk_library> ", sum(x$rows), " runs of ", ncol(x$theta),
                " parameter(s) in ", length(x$files), " chunk(s) at ", x$dir)
  cli::cat_line("  x:     ", if (is.null(x$x)) "one setting" else
    paste0(nrow(x$x), " setting(s) of ", paste(names(x$x), collapse = ", ")))
  cli::cat_line("  t:     ", length(x$t), " output(s)")
  cli::cat_line("  y:     ", sum(x$rows), " x ", x$n_out, " (runs x outputs, ",
                format(structure(8 * sum(x$rows) * x$n_out, class = "object_size"),
                       units = "auto"), " in memory)")
  invisible(x)
}

# C of a disk library: one quad_forms_cpp() call per chunk, mapped over the
# future plan's workers in waves of one chunk per worker, each wave's results
# copied into C at once: memory holds C and one wave of chunk results.
disk_quad_forms <- function(library, y_field, setup) {
  chunk_C <- function(file, y_field, Rx_inv, phi) {
    quad_forms_cpp(readRDS(file), y_field, Rx_inv, phi)
  }
  environment(chunk_C) <- asNamespace("griddy")
  parallel <- requireNamespace("future.apply", quietly = TRUE)
  map <- if (parallel) {
    function(...) future.apply::future_lapply(..., future.seed = NULL,
                                              future.packages = "griddy")
  } else {
    lapply
  }
  per_wave <- if (parallel) max(1L, as.integer(future::nbrOfWorkers())) else 1L
  ends <- cumsum(library$rows)
  C <- matrix(0, sum(library$rows), dim(setup$Rx_inv)[3] * ncol(setup$phi))
  for (wave in split(seq_along(library$files), (seq_along(library$files) - 1L) %/% per_wave)) {
    pieces <- map(library$files[wave], chunk_C, y_field = y_field, Rx_inv = setup$Rx_inv,
                  phi = setup$phi)
    for (j in seq_along(wave)) {
      k <- wave[j]
      C[ends[k] - library$rows[k] + seq_len(library$rows[k]), ] <- pieces[[j]]
    }
  }
  C
}

lib_quad_forms.disk_library <- function(library, y_field, setup) {
  disk_quad_forms(library, y_field, setup)
}

lib_check_integrity.disk_library <- function(library) invisible(library)

lib_outputs.disk_library <- function(library, rows = NULL) {
  runs <- lib_check_rows(library, rows)
  ends <- cumsum(library$rows)
  chunk <- findInterval(runs - 1L, ends) + 1L
  out <- matrix(0, length(runs), library$n_out)
  for (k in unique(chunk)) {
    at <- which(chunk == k)
    y <- readRDS(library$files[k])
    out[at, ] <- y[runs[at] - (ends[k] - library$rows[k]), , drop = FALSE]
  }
  out
}
