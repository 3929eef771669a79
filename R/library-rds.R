# Libraries stored as a directory of .rds chunks (the first on-disk format):
# read only. New libraries on disk are HDF5 files (write_library(),
# hdf5_library()).

#' Write a simulation library to disk in chunks (defunct)
#'
#' `write_library_chunks()` is defunct: use [write_library()], which writes an
#' HDF5 file that [hdf5_library()] opens. Directories written by earlier
#' versions are still read by [disk_library()], and
#' `write_library(disk_library(dir, trust = TRUE), file)` converts one.
#'
#' Why defunct rather than deprecated: its format cannot be appended to
#' safely. An append must change two files, `theta.rds` and `manifest.rds`,
#' and a writer that died between them left a library that opened with the
#' parameters and the outputs out of step, which a second append could not
#' repair; two writers appending at once both reported success while one's
#' runs were lost or mixed. Fixing both would have meant a new format and a
#' lock, which [write_library()] now provides (a committed-run count updated
#' last, and a lock refusing a second writer), so the old writer was retired
#' rather than kept as a second, weaker, way to write a library.
#'
#' @param ... Ignored.
#' @return Does not return: it stops with a message pointing to
#'   [write_library()].
#' @seealso [write_library()], [disk_library()], [repair_library()]
#' @examples
#' try(write_library_chunks())
#' @export
write_library_chunks <- function(...) {
  .Defunct("write_library", package = "griddy", msg = paste0(
    "write_library_chunks() is defunct: its .rds chunk directories cannot be appended to ",
    "safely. Use write_library(library, file, append = ) to write an HDF5 library and ",
    "hdf5_library(file) to open it; disk_library(dir, trust = TRUE) still reads old directories and ",
    "write_library(disk_library(dir, trust = TRUE), file) converts one. See ?write_library_chunks."))
}

#' A simulation library stored on disk in chunks (old format)
#'
#' Opens a directory of `.rds` chunks written by `write_library_chunks()` in
#' earlier versions of griddy (that writer is now defunct: new libraries on
#' disk are HDF5 files, see [write_library()] and [hdf5_library()]). Only the
#' parameter values (`N x p`) are read into memory; the outputs stay in the
#' chunk files. [calibrate()] and [posterior_exact()] read the chunks one at a
#' time to compute the quadratic forms \eqn{C_{ig}}, so memory holds the
#' `N x G` table of \eqn{C_{ig}} and one chunk per worker, never the whole
#' library.
#'
#' The chunks are mapped with [future.apply::future_lapply()], so the same
#' call runs sequentially (the default plan), on local cores
#' (`future::plan("multisession")`), or on a cluster or a batch queue through
#' any future backend the user chooses (for example future.batchtools for
#' Slurm), without a change to the calibration code. The workers need griddy
#' installed and must see `dir`. Without future.apply the chunks are read
#' sequentially.
#'
#' The directory is checked when it is opened (the manifest, the parameter
#' values and the chunk files must agree) and every chunk when it is read (its
#' dimensions against the manifest, its values finite); a damaged library
#' stops with an error of class `griddy_error_library` naming the file at
#' fault. A directory left by an append that died between writing
#' `theta.rds` and `manifest.rds` (more parameter rows than chunk rows) is
#' reported with the fix: [repair_library()] cuts `theta.rds` back to the runs
#' the manifest lists.
#'
#' @section Security: An `.rds` file is R's serialization format, and reading
#'   one can run code hidden in it: a crafted `theta.rds` runs arbitrary code
#'   when it is read (CVE-2024-27322, fixed in R 4.4.0; R's serialization is
#'   not meant for untrusted data on any version). `disk_library()` therefore
#'   reads a directory only when told it is trusted, `trust = TRUE`, on every
#'   R version; otherwise it stops, before reading any file, with an error of
#'   class `griddy_error_untrusted`. Open with `trust = TRUE` only directories
#'   you (or someone you trust) wrote, and convert them once to HDF5, which
#'   holds data only: `write_library(disk_library(dir, trust = TRUE), file)`,
#'   then [hdf5_library()]`(file)`.
#'
#' @param dir Directory holding the library.
#' @param trust `TRUE` to read the `.rds` files of `dir`: only for a
#'   directory you trust (see the section on security). The default refuses.
#' @return An object of class `disk_library`: a list with the directory
#'   `dir`, the chunk `files` and their `rows`, the parameter values `theta`
#'   (a data.frame), the settings `x`, coordinates `t` and the number of
#'   outputs per run `n_out`.
#' @seealso [hdf5_library()], [write_library()], [repair_library()],
#'   [calibrate()]
#' @examples
#' # a directory in the old format, as write_library_chunks() wrote it
#' ex <- griddy_example()
#' dir <- file.path(tempdir(), "example-library-rds")
#' dir.create(dir)
#' y <- ex$library$y
#' saveRDS(y[1:100, ], file.path(dir, "chunk-000001.rds"))
#' saveRDS(y[-(1:100), ], file.path(dir, "chunk-000002.rds"))
#' saveRDS(ex$library$theta, file.path(dir, "theta.rds"))
#' saveRDS(list(x = ex$library$x, t = ex$library$t,
#'              theta_names = names(ex$library$theta), n_out = ncol(y),
#'              files = c("chunk-000001.rds", "chunk-000002.rds"),
#'              rows = c(100L, nrow(y) - 100L)), file.path(dir, "manifest.rds"))
#' lib <- disk_library(dir, trust = TRUE) # we wrote it ourselves
#' lib
#' fit <- calibrate(lib, ex$field, n_iter = 1000, burn_in = 200, seed = 1)
#' fit
#' unlink(dir, recursive = TRUE)
#' @export
disk_library <- function(dir, trust = FALSE) {
  dir <- assert_string(dir, "dir")
  trust <- assert_flag(trust, "trust")
  manifest_file <- file.path(dir, "manifest.rds")
  if (!file.exists(manifest_file)) {
    griddy_abort("`dir` (", dir, ") holds no library written by write_library_chunks(): ",
                 "it has no manifest.rds.", class = "library")
  }
  assert_trusted_rds(dir, trust, "disk_library")
  dir <- normalizePath(dir)
  m <- read_rds_checked(file.path(dir, "manifest.rds"), "The manifest")
  if (!is.list(m) || !is.character(m$files) || !is.numeric(m$rows) ||
      length(m$files) != length(m$rows) || length(m$files) == 0L ||
      any(!is.finite(m$rows) | m$rows < 1) || !is.numeric(m$n_out) || length(m$n_out) != 1L ||
      !is.numeric(m$t)) {
    griddy_abort("The manifest ", file.path(dir, "manifest.rds"), " is not a library manifest ",
                 "(it needs `files`, `rows`, `n_out`, `x` and `t`): the library is damaged.",
                 class = "library")
  }
  files <- file.path(dir, m$files)
  missing <- !file.exists(files)
  if (any(missing)) {
    griddy_abort("The library in ", dir, " lacks chunk file(s) ", show_some(m$files[missing]),
                 " that its manifest lists: it is damaged; rewrite it from the simulator's ",
                 "outputs.", class = "library")
  }
  theta <- read_rds_checked(file.path(dir, "theta.rds"), "The parameter values")
  if (!is.data.frame(theta)) {
    griddy_abort("The parameter values ", file.path(dir, "theta.rds"), " are not a data.frame ",
                 "but ", class(theta)[1], ": the library is damaged.", class = "library")
  }
  n_chunk_rows <- sum(m$rows)
  if (nrow(theta) != n_chunk_rows) {
    griddy_abort(rds_out_of_step(dir, nrow(theta), n_chunk_rows), class = "library")
  }
  assert_library_size(n_chunk_rows, paste0("The library in ", dir))
  theta <- as.data.frame(tryCatch(as_theta_matrix(theta), griddy_error = function(e) {
    griddy_abort("The parameter values ", file.path(dir, "theta.rds"), " are damaged: ",
                 conditionMessage(e), class = "library")
  }))
  lib <- structure(
    list(dir = dir, files = files, rows = as.integer(m$rows), theta = theta, x = m$x,
         t = as.double(m$t), n_out = as.integer(m$n_out)),
    class = "disk_library"
  )
  if (lib_n_out(lib) != lib$n_out) {
    griddy_abort("The manifest ", file.path(dir, "manifest.rds"), " gives ", lib$n_out,
                 " outputs per run but its x and t give ", lib_n_x(lib), " x ", lib_n_t(lib),
                 ": the library is damaged.", class = "library")
  }
  lib
}

# Refuses to read the .rds files of `dir` unless the caller said it trusts
# them: readRDS() can run code hidden in a file (CVE-2024-27322).
assert_trusted_rds <- function(dir, trust, fun) {
  if (isTRUE(trust)) return(invisible(dir))
  griddy_abort(fun, "() reads the .rds files in ", dir, ", and reading an .rds file can run ",
               "code hidden in it (CVE-2024-27322, fixed in R 4.4.0; R's serialization is not ",
               "meant for untrusted data), so it reads a directory only when told to trust ",
               "it. If you (or someone you trust) wrote it, call ", fun, "(dir, trust = TRUE), ",
               "and convert it once to HDF5, which holds data only: ",
               "write_library(disk_library(dir, trust = TRUE), file), then hdf5_library(file).",
               class = "untrusted")
}

# The message for a directory whose theta.rds and manifest.rds disagree.
rds_out_of_step <- function(dir, n_theta, n_chunk_rows) {
  paste0("The library in ", dir, " is incomplete: theta.rds has ", n_theta,
         " runs but the chunks listed in manifest.rds hold ", n_chunk_rows, ". ",
         if (n_theta > n_chunk_rows) {
           paste0("An append died between writing theta.rds and manifest.rds. Run ",
                  "repair_library(\"", dir, "\", trust = TRUE) to cut theta.rds back to the ", n_chunk_rows,
                  " runs the manifest lists (the unfinished append's ", n_theta - n_chunk_rows,
                  " runs are dropped), then write them again, e.g. after converting the ",
                  "library to HDF5 with write_library(disk_library(dir, trust = TRUE), file).")
         } else {
           paste0("theta.rds has fewer runs than the chunks, which no interrupted append ",
                  "leaves: the library cannot be repaired; rewrite it from the simulator's ",
                  "outputs.")
         })
}

# readRDS() with griddy's message when the file is missing or corrupt.
read_rds_checked <- function(file, what) {
  damaged <- function(cnd) {
    why <- if (file.exists(file)) {
      paste0(" cannot be read: it is corrupt or truncated (", conditionMessage(cnd), ")")
    } else {
      " is missing"
    }
    griddy_abort(what, " ", file, why, "; the library is damaged: rewrite it from the ",
                 "simulator's outputs.", class = "library")
  }
  # readRDS(file) leaves a connection behind when the file cannot be opened;
  # one created here is always destroyed (future warns about leaked ones)
  con <- gzfile(file)
  on.exit(close(con))
  tryCatch({
    open(con, "rb")
    readRDS(con)
  }, error = damaged, warning = damaged)
}

#' @export
print.disk_library <- function(x, ...) {
  cli::cat_line("<disk_library> ", sum(x$rows), " runs of ", ncol(x$theta),
                " parameter(s) in ", length(x$files), " .rds chunk(s) at ", x$dir)
  cli::cat_line("  x:     ", if (is.null(x$x)) "one setting" else
    paste0(nrow(x$x), " setting(s) of ", paste(names(x$x), collapse = ", ")))
  cli::cat_line("  t:     ", length(x$t), " output(s)")
  cli::cat_line("  y:     ", sum(x$rows), " x ", x$n_out, " (runs x outputs, ",
                format(structure(8 * sum(x$rows) * x$n_out, class = "object_size"),
                       units = "auto"), " in memory)")
  invisible(x)
}

# ---- the library interface, chunks on disk (see library.R) -------

# One chunk file, checked against the manifest.
rds_piece <- function(library, k) {
  structure(list(file = library$files[k], rows = library$rows[k], n_out = library$n_out,
                 first = sum(library$rows[seq_len(k - 1L)]) + 1L), class = "rds_piece")
}

#' @exportS3Method
read_piece.rds_piece <- function(piece) {
  y <- read_rds_checked(piece$file, "The chunk file")
  check_piece(y, piece$rows, piece$n_out, paste0("The chunk file ", piece$file),
              piece$first)
}

#' @exportS3Method
lib_quad_forms.disk_library <- function(library, y_field, setup) {
  pieces <- lapply(seq_along(library$files), rds_piece, library = library)
  chunked_quad_forms(pieces, library$rows, y_field, setup)
}

#' @exportS3Method
lib_on_disk.disk_library <- function(library) TRUE

#' @exportS3Method
lib_check_integrity.disk_library <- function(library) {
  files <- library$files
  rows <- library$rows
  if (!is.character(files) || !is.numeric(rows) || length(files) != length(rows) ||
      length(rows) == 0L || anyNA(rows) || any(rows < 1) || !is.numeric(library$n_out) ||
      length(library$n_out) != 1L) {
    griddy_abort("The disk_library has been edited: `files` and `rows` must list each chunk ",
                 "file and its number of runs. Open it again with disk_library().",
                 class = "shape")
  }
  check_library_parts(library, sum(rows), library$n_out, "disk_library",
                      fix = "Open it again with disk_library().")
}

#' @exportS3Method
lib_outputs.disk_library <- function(library, rows = NULL) {
  runs <- lib_check_rows(library, rows)
  ends <- cumsum(library$rows)
  chunk <- findInterval(runs - 1L, ends) + 1L
  out <- matrix(0, length(runs), library$n_out)
  for (k in unique(chunk)) {
    at <- which(chunk == k)
    y <- read_piece(rds_piece(library, k))
    out[at, ] <- y[runs[at] - (ends[k] - library$rows[k]), , drop = FALSE]
  }
  out
}

# Repairs a directory left by an append that died between theta.rds and
# manifest.rds: theta.rds is cut to the runs the manifest lists (written to a
# temporary file and renamed over it), and chunk files the manifest does not
# list (written by the unfinished append) are removed.
repair_rds_library <- function(dir, trust) {
  assert_trusted_rds(dir, trust, "repair_library")
  dir <- normalizePath(dir)
  token <- library_lock(dir, "library directory", recover = function() "repairing it.")
  on.exit(library_unlock(token), add = TRUE)
  m <- read_rds_checked(file.path(dir, "manifest.rds"), "The manifest")
  theta <- read_rds_checked(file.path(dir, "theta.rds"), "The parameter values")
  n_keep <- sum(m$rows)
  orphans <- setdiff(list.files(dir, pattern = "^chunk-[0-9]+\\.rds$"), m$files)
  if (nrow(theta) < n_keep) {
    griddy_abort(rds_out_of_step(dir, nrow(theta), n_keep), class = "library")
  }
  dropped <- nrow(theta) - n_keep
  if (dropped > 0L) {
    tmp <- file.path(dir, "theta.rds.repair")
    saveRDS(theta[seq_len(n_keep), , drop = FALSE], tmp)
    file.rename(tmp, file.path(dir, "theta.rds"))
  }
  unlink(file.path(dir, orphans))
  list(path = dir, runs = n_keep, dropped = dropped, removed_files = orphans)
}
