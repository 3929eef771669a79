# Libraries in HDF5 files, through hdf5r: a reader for files any pipeline
# wrote (hdf5_library()), and griddy's own writer with safe appends
# (write_library(), repair_library()).
#
# Orientation. HDF5 stores arrays in row-major (C) order and lists dimensions
# slowest first; h5py, NumPy, h5dump and h5ls show them that way. R is
# column-major, and hdf5r reverses the dimensions so that the bytes need no
# reordering: an array h5py wrote as runs x outputs arrives in R as outputs x
# runs. griddy names a dataset's orientation by the HDF5 order, as h5dump and
# h5py show it: "runs_first" (runs x outputs: what h5py/NumPy write for an
# N x n array) or "runs_last" (outputs x runs: what R, MATLAB or Fortran write
# for an N x n matrix). In hdf5r's R dimensions, runs_first means runs on the
# second dimension.

#' A simulation library in an HDF5 file
#'
#' Opens a library held in an HDF5 file, written by [write_library()] or by
#' the user's own pipeline (h5py, R, MATLAB, ...), without converting it. Only
#' the parameter values (`N x p`), the settings and the coordinates are read
#' into memory; the outputs stay in the file and are read `chunk_size` runs at
#' a time. [calibrate()] and [posterior_exact()] accept the result in place of
#' a [sim_library()]: they compute the quadratic forms \eqn{C_{ig}} chunk by
#' chunk, mapped with [future.apply::future_lapply()] over the user's
#' `future::plan()` in waves of one chunk per worker (sequentially under the
#' default plan or without future.apply), so memory holds the `N x G` table of
#' \eqn{C_{ig}} and one chunk per worker, never the whole library. Workers
#' need griddy and hdf5r installed and must see `file`.
#'
#' @section Orientation: HDF5 lists a dataset's dimensions in row-major order,
#'   as `h5dump`, `h5ls` and h5py show them. An outputs dataset is
#'   `"runs_first"` when its dimensions in that order are runs x outputs (what
#'   h5py or NumPy write for an `N x n` array) and `"runs_last"` when they are
#'   outputs x runs (what R through hdf5r or rhdf5, MATLAB and Fortran write
#'   for an `N x n` matrix: R's column-major matrix lands transposed). With
#'   `layout = "auto"` griddy finds the runs dimension as the one whose length
#'   is the number of runs in `theta` (and, when `x` and `t` fix the number
#'   of outputs, the other one as that number); a dataset whose two
#'   dimensions both fit is ambiguous and refused: give `layout`. A
#'   two-dimensional numeric `theta` (or `x`) is oriented the same way, its
#'   parameter dimension having one entry per name.
#'
#' @section Parameter names: `theta` may be a compound dataset (one field per
#'   parameter: what h5py writes for a NumPy structured array and hdf5r for a
#'   data.frame), a one-dimensional numeric dataset (one parameter), or a
#'   two-dimensional numeric one. The parameter names are `theta_names` when
#'   given (for a compound dataset they select and order its fields);
#'   otherwise the field names, or the dataset's attribute `names` or
#'   `column_names`. The same holds for an `x` dataset, whose names come from
#'   its fields or attributes (a one-dimensional `x` is named `x`).
#'
#' @section Damaged files: A dataset's dimensions are checked against the
#'   bytes it stores before anything is read: one that claims more than 1100
#'   times what it stores (compression explains at most about 1032:1 for
#'   HDF5's deflate), such as a few-kB file declaring 10^9 runs that were
#'   never written, is refused with an error of class
#'   `griddy_error_library` rather than allocated. A committed-run count that
#'   is not one whole number is refused the same way.
#'
#' @section Text: A string dataset (what h5py writes for text, or hdf5r
#'   for a character vector) of `theta` (one-dimensional), `t` or `x` is read
#'   when every entry is a number written as text; other text, outputs stored
#'   as text, and text fields of a compound `theta` or `x` are refused with
#'   an error of class `griddy_error_unsupported` naming the dataset (for a
#'   compound `theta`, `theta_names` selects its numeric fields).
#'
#' @section Files written by write_library(): They carry the attribute
#'   `griddy_format` and a committed-run count `griddy_n_runs`, updated last by
#'   every append. Readers use only the committed runs: the rows of an append
#'   that died part-way are ignored (with a warning saying how to discard
#'   them, see [repair_library()]). A file another process is appending to
#'   is opened as an SWMR reader (see [write_library()]): the reader sees the
#'   runs committed when it opened the file. For these files the arguments `theta`,
#'   `outputs`, `x`, `t` and `layout` can be left out.
#'
#' @param file Path to the HDF5 file.
#' @param theta Name (path) of the dataset of parameter values, one entry per
#'   run.
#' @param outputs Name (path) of the dataset of outputs: runs by outputs per
#'   run (`n_x * n_t`, in blocks by x setting as in [sim_library()]), in
#'   either orientation. A one-dimensional dataset is one output per run.
#' @param x The control settings: `NULL` (one setting), a data.frame or numeric
#'   vector as in [sim_library()], or the name of a dataset in `file`.
#' @param t The output coordinates: `NULL` (`1:n_t`), a numeric vector, or the
#'   name of a one-dimensional dataset in `file`.
#' @param theta_names Parameter names, when the `theta` dataset does not carry
#'   them; see the section on parameter names.
#' @param layout `"auto"`, `"runs_first"` or `"runs_last"`: the orientation of
#'   the two-dimensional datasets (see the section on orientation). One value
#'   for all, or a named vector with elements among `theta`, `outputs` and `x`.
#' @param chunk_size Runs per read. `NULL` reads about 64 MB of outputs at a
#'   time.
#' @return An object of class `hdf5_library`: a list with the normalised path
#'   `file`, the `outputs` dataset and its `layout`, the parameter values
#'   `theta` (a data.frame), the settings `x`, the coordinates `t`, the number
#'   of runs `n_runs` and of outputs per run `n_out`, `chunk_size` and
#'   `committed` (whether the file was written by [write_library()]).
#' @seealso [write_library()], [repair_library()], [sim_library()],
#'   [calibrate()]
#' @examples
#' if (requireNamespace("hdf5r", quietly = TRUE)) {
#'   ex <- griddy_example()
#'   file <- tempfile(fileext = ".h5")
#'   # a file as the user's own pipeline might write it: theta a compound
#'   # dataset, the outputs a runs x outputs array written from R (so
#'   # "runs_last" in HDF5's order)
#'   h5 <- hdf5r::H5File$new(file, "w")
#'   h5[["design"]] <- ex$library$theta
#'   h5[["outputs"]] <- ex$library$y
#'   h5[["time"]] <- ex$library$t
#'   h5$close_all()
#'   lib <- hdf5_library(file, theta = "design", outputs = "outputs",
#'                       x = ex$library$x, t = "time")
#'   lib
#'   exact <- posterior_exact(lib, ex$field)
#'   unlink(file)
#' }
#' @export
hdf5_library <- function(file, theta = "theta", outputs = "y", x = NULL, t = NULL,
                         theta_names = NULL, layout = "auto", chunk_size = NULL) {
  require_package("hdf5r", "to read a library from an HDF5 file")
  file <- assert_string(file, "file")
  if (!file.exists(file)) {
    griddy_abort("`file` (", file, ") does not exist.")
  }
  file <- normalizePath(file)
  if (!is.null(theta_names)) {
    if (!is.character(theta_names) || length(theta_names) < 1L || anyNA(theta_names) ||
        any(theta_names == "")) {
      griddy_abort("`theta_names` must be a character vector of parameter names; received ",
                   paste(format(theta_names), collapse = ", "), ".")
    }
  }
  h5 <- h5_open(file, "r")
  on.exit(h5_close(h5), add = TRUE)
  meta <- h5_griddy_meta(h5)
  if (meta$griddy) {
    if (missing(theta)) theta <- "theta"
    if (missing(outputs)) outputs <- "y"
    if (missing(x) && h5$exists("x")) x <- "x"
    if (missing(t) && h5$exists("t")) t <- "t"
    if (missing(layout)) layout <- "runs_last"
  }
  layout <- as_layout(layout)

  theta_ds <- h5_dataset(h5, theta, "theta", file)
  theta_tab <- h5_read_table(theta_ds, theta_names, layout[["theta"]], "theta", theta, file,
                             max_rows = if (meta$griddy) meta$n_runs)
  x <- if (is.character(x)) {
    x_ds <- h5_dataset(h5, x, "x", file)
    as.data.frame(h5_read_table(x_ds, NULL, layout[["x"]], "x", x, file, one_d_name = "x"))
  } else {
    x
  }
  x <- as_settings(x, "x")
  n_x <- n_settings(x)
  if (is.character(t)) {
    t_ds <- h5_dataset(h5, t, "t", file)
    t <- h5_read_vector(t_ds, "t", t, file)
  }

  out_ds <- h5_dataset(h5, outputs, "outputs", file)
  out_cls <- as.character(out_ds$get_type()$get_class())
  if (!out_cls %in% c("H5T_FLOAT", "H5T_INTEGER")) {
    griddy_abort("`outputs`: dataset '", outputs, "' in ", file, " holds ",
                 h5_class_words(out_cls), ", which griddy does not read as outputs: they ",
                 "must be stored as numbers (integer or floating point). Write them as ",
                 "numbers, e.g. with write_library().", class = "unsupported")
  }
  h5_check_stored(out_ds, "outputs", outputs, file)
  dims <- rev(out_ds$dims)
  n_theta <- attr(theta_tab, "rows_stored")
  n_out_known <- if (!is.null(t)) n_x * length(t) else NULL
  if (length(dims) == 1L) {
    out_layout <- "runs_first"
    dims <- c(dims, 1L)
  } else if (length(dims) == 2L) {
    out_layout <- h5_orient(dims, layout[["outputs"]], if (meta$griddy) NULL else n_theta,
                            n_out_known, "outputs", outputs, "outputs per run", file)
  } else {
    griddy_abort("`outputs`: dataset '", outputs, "' in ", file, " must have one or two ",
                 "dimensions (runs and outputs); it has ", length(dims), " (",
                 paste(dims, collapse = " x "), ").")
  }
  n_ext <- if (out_layout == "runs_first") dims[1] else dims[2]
  n_out <- as.integer(if (out_layout == "runs_first") dims[2] else dims[1])

  if (meta$griddy) {
    n_runs <- meta$n_runs
    if (n_theta < n_runs || n_ext < n_runs) {
      griddy_abort(file, " is damaged: it records ", n_runs, " committed runs but dataset '",
                   theta, "' holds ", n_theta, " and '", outputs, "' ", n_ext, ".",
                   class = "library")
    }
    if (n_theta > n_runs || n_ext > n_runs) {
      h5_warn_uncommitted(file, n_runs, max(n_theta, n_ext))
    }
  } else {
    if (n_ext != n_theta) {
      griddy_abort("`theta` and `outputs` must have one entry per run: dataset '", theta,
                   "' in ", file, " holds ", n_theta, " runs but '", outputs, "' ", n_ext,
                   " (dimensions ", paste(dims, collapse = " x "), " as h5dump shows them).",
                   class = "shape")
    }
    n_runs <- n_theta
  }
  assert_library_size(n_runs, paste0("Dataset '", theta, "' in ", file,
                                     if (meta$griddy) " (committed runs)"))
  theta_mat <- as_theta_matrix(theta_tab[seq_len(n_runs), , drop = FALSE])
  rownames(theta_mat) <- NULL
  if (n_out %% n_x != 0L) {
    griddy_abort("`outputs` has ", n_out, " outputs per run, which is not a multiple of the ",
                 n_x, " x settings (rows of `x`).")
  }
  t <- as_coordinates(t, n_out %/% n_x, "t", "outputs per run and x setting")
  assert_distinct_runs(theta_mat)
  warn_constant_columns(theta_mat)
  if (is.null(chunk_size)) {
    chunk_size <- max(1L, as.integer(min(n_runs, floor(2^23 / n_out))))
  }
  chunk_size <- assert_count(chunk_size, "chunk_size")
  structure(
    list(file = file, outputs = outputs, layout = out_layout, theta = as.data.frame(theta_mat),
         x = x, t = t, n_runs = as.integer(n_runs), n_out = n_out,
         chunk_size = min(chunk_size, as.integer(n_runs)), committed = meta$griddy),
    class = "hdf5_library"
  )
}

#' @export
print.hdf5_library <- function(x, ...) {
  ranges <- vapply(x$theta, function(v) {
    paste0(format(min(v), digits = 4), " to ", format(max(v), digits = 4))
  }, "")
  cli::cat_line("<hdf5_library> ", x$n_runs, " runs of ", ncol(x$theta),
                " parameter(s) in ", x$file)
  cli::cat_line("  theta: ", paste0(names(ranges), " [", ranges, "]", collapse = ", "))
  cli::cat_line("  x:     ", if (is.null(x$x)) "one setting" else
    paste0(nrow(x$x), " setting(s) of ", paste(names(x$x), collapse = ", ")))
  cli::cat_line("  t:     ", length(x$t), " output(s), ",
                format(min(x$t), digits = 4), " to ", format(max(x$t), digits = 4))
  cli::cat_line("  y:     ", x$n_runs, " x ", x$n_out, " (runs x outputs, ",
                format(structure(8 * x$n_runs * x$n_out, class = "object_size"),
                       units = "auto"), " in memory) from dataset '", x$outputs, "', ",
                if (x$layout == "runs_first") "runs first" else "runs last",
                " in HDF5's order; read ", x$chunk_size, " runs at a time")
  if (isTRUE(x$committed)) {
    cli::cat_line("  written by write_library(): ", x$n_runs, " committed runs")
  }
  invisible(x)
}

#' Write a simulation library to an HDF5 file
#'
#' Writes a library to an HDF5 file that [hdf5_library()] opens. With
#' `append = TRUE` the runs are added after those already in `file`, so a
#' library larger than memory can be written piece by piece as the simulator
#' produces it; any library can be written, so
#' `write_library(disk_library(dir, trust = TRUE), file)` converts an old `.rds` chunk
#' directory, reading it a piece at a time.
#'
#' @section Safe appends: An append first extends the datasets and writes the
#'   new runs, then, last, updates the file's committed-run count (the
#'   attribute `griddy_n_runs`). Readers use only committed runs, so a writer
#'   that dies part-way leaves the library as it was, plus rows that are
#'   ignored; [hdf5_library()] warns about them, and [repair_library()] or the
#'   next append discards them. An append that fails with an error cuts its
#'   own rows. A new file is built under a temporary name and renamed into
#'   place, so it either exists whole (with no runs yet) or not at all. (The
#'   order holds against a writer that is killed or fails; on a power cut,
#'   what reaches the disk depends on the file system.)
#'
#' @section A full disk: Before it writes, an append makes sure the device
#'   has room for its runs (it writes that many bytes past the end of the
#'   file and cuts them off again), so a full disk, a quota or a file-size
#'   limit stops it with an error of class `griddy_error_disk` before the
#'   file is touched; the library keeps its committed runs. A write that
#'   fails in HDF5 all the same (the disk filled meanwhile) stops with
#'   `griddy_error_disk` or `griddy_error_io`, its handles closed.
#'
#' @section One writer at a time: A writer holds the lock `<file>.lock` (a
#'   directory, created atomically, recording the writer's process id, host,
#'   start time, the machine's boot id and the process's start tick) for the
#'   whole write. A second writer is refused with an error of class
#'   `griddy_error_lock` naming the holder, never mixed in. A lock left by a
#'   writer that died (killed, say) is recovered by the next writer on the
#'   same host when it opens the file, as SQLite recovers a hot journal: it
#'   finds the owner dead (no such process, another boot, or the process id
#'   reused), takes the lock over, discards the runs the dead writer left
#'   uncommitted, and says so in a message of class
#'   `griddy_message_lock_recovered`; [simulate_library()] does this before
#'   it simulates anything. A lock held from another host is never broken
#'   (griddy cannot tell a dead writer there from a slow one): the error says
#'   how to remove it.
#'
#' @section Readers during a write: Files written by this version use
#'   HDF5's latest file format (HDF5 1.10 or later reads them), and appends
#'   open them in HDF5's single-writer/multiple-reader (SWMR) mode: a reader
#'   (such as [hdf5_library()] and a calibration from it) opens the file
#'   while another process appends and sees the committed runs, never a
#'   half-written one. Files written by earlier versions are appended to as
#'   before, and HDF5 refuses their readers for the length of an append (a
#'   reader waits up to a minute); `write_library(hdf5_library(old), new)`
#'   converts one.
#'
#' @param library A library: a [sim_library()] (all runs, or the next piece
#'   with `append = TRUE`), an [hdf5_library()] or a [disk_library()].
#' @param file Path of the HDF5 file. Without `append` it must not exist.
#' @param append Add the runs to the library already in `file` (written by
#'   `write_library()`; same parameters, settings `x` and coordinates `t`;
#'   no run may repeat one already there).
#' @param chunk_size Runs per HDF5 storage chunk when the file is created
#'   (ignored when appending). `NULL` gives chunks of about 1 MB.
#' @return The [hdf5_library()] in `file`, invisibly.
#' @seealso [hdf5_library()], [repair_library()]
#' @examples
#' if (requireNamespace("hdf5r", quietly = TRUE)) {
#'   ex <- griddy_example()
#'   lib <- ex$library
#'   file <- tempfile(fileext = ".h5")
#'   # the library written in two pieces, as a simulator might produce it
#'   first <- 1:100
#'   write_library(sim_library(lib$theta[first, ], lib$y[first, ], x = lib$x, t = lib$t),
#'                 file)
#'   rest <- seq(101, nrow(lib$y))
#'   disk <- write_library(sim_library(lib$theta[rest, ], lib$y[rest, ], x = lib$x,
#'                                     t = lib$t), file, append = TRUE)
#'   disk
#'   fit <- calibrate(disk, ex$field, n_iter = 1000, burn_in = 200, seed = 1)
#'   unlink(file)
#' }
#' @export
write_library <- function(library, file, append = FALSE, chunk_size = NULL) {
  require_package("hdf5r", "to write a library to an HDF5 file")
  check_library(library)
  file <- assert_string(file, "file")
  append <- assert_flag(append, "append")
  if (!is.null(chunk_size)) chunk_size <- assert_count(chunk_size, "chunk_size")
  if (dir.exists(file)) {
    griddy_abort("`file` (", file, ") is a directory; give the path of an HDF5 file.")
  }
  commit_runs(library, file, append, chunk_size)
  invisible(hdf5_library(file))
}

# write_library()'s work, without opening the result: under the lock, the
# file created (append = FALSE) and the runs of `library` (any number, one
# is enough) appended and committed.
commit_runs <- function(library, file, append, chunk_size = NULL) {
  token <- library_lock(file, "library file", recover = function() h5_recover(file))
  on.exit(library_unlock(token), add = TRUE)
  write_hook("locked")
  if (append) {
    if (!file.exists(file)) {
      griddy_abort("`file` (", file, ") holds no library to append to: write the first ",
                   "piece with `append = FALSE`.")
    }
  } else {
    if (file.exists(file)) {
      griddy_abort("`file` (", file, ") already exists; use `append = TRUE` to add runs to ",
                   "the library in it, or choose a new file.")
    }
    h5_guard_write(file, h5_create_library(library, file, chunk_size), created = TRUE)
  }
  n <- h5_guard_write(file, h5_append_runs(library, file))
  write_hook("done")
  invisible(n)
}

# Runs a write, turning an error of HDF5's (hdf5r's raw stack) into a
# classed one: `griddy_error_disk` when the device is full or the file over
# a size limit, `griddy_error_io` for other failures of the write. The
# committed runs are not touched by a failed append (the count is written
# last), so the message says how to go on.
h5_guard_write <- function(file, expr, created = FALSE) {
  tryCatch(expr, error = function(e) {
    if (inherits(e, "griddy_error")) stop(e)
    msg <- conditionMessage(e)
    disk <- grepl("errno = (27|28|122)\\b|No space left|File too large|quota exceeded", msg,
                  ignore.case = TRUE)
    griddy_abort(
      "Writing ", file, " failed",
      if (disk) ": the disk is full (or the file reached a size limit)" else "",
      " (", h5_error_summary(e), if (disk) paste0("; ", h5_errno_text(msg)), "). ",
      if (created) "The new file was not created." else paste0(
        "Its committed runs are intact; the rows of this append are not committed. ",
        "Run repair_library(\"", file, "\") to discard them"),
      if (!created && disk) ", free some space," else if (!created) "," else "",
      if (!created) " and write the runs again.",
      class = if (disk) "disk" else "io")
  })
}

h5_errno_text <- function(msg) {
  hit <- regmatches(msg, regexpr("error message = '[^']*'", msg))
  if (length(hit) == 0L) "" else sub("error message = '([^']*)'", "the system says: \\1", hit)
}

# Repairs a file whose writer died (called under its lock, taken over from
# the dead writer): clears the superblock's mark of a writer at work, which
# HDF5 leaves on a file in the latest format, and cuts the uncommitted rows.
# Returns a sentence for the message that reports the recovery.
h5_recover <- function(file) {
  unlink(Sys.glob(paste0(file, ".new-*"))) # a new file the dead writer was building
  if (!file.exists(file)) return("no file was left to repair.")
  h5 <- h5_open(file, "r+", clear = TRUE)
  on.exit(h5_close(h5), add = TRUE)
  meta <- h5_griddy_meta(h5)
  if (!meta$griddy) return("the file is not griddy's, so it was left as it is.")
  dropped <- h5_drop_uncommitted(h5, meta$n_runs)
  paste0("the file keeps its ", meta$n_runs, " committed runs",
         if (dropped > 0L) paste0(" and the ", dropped, " uncommitted run(s) it left were ",
                                  "discarded") else "", ".")
}

# A dead writer's lock is recovered when a writer opens the file, before it
# does any work (simulate_library() calls this before simulating).
h5_recover_dead_writer <- function(file) {
  lock <- lock_path(file)
  if (dir.exists(lock) && lock_is_stale(lock_owner(lock))) {
    token <- tryCatch(library_lock(file, "library file", recover = function() h5_recover(file)),
                      griddy_error_lock = function(e) NULL) # another writer came first
    if (!is.null(token)) library_unlock(token)
  }
  invisible(file)
}

#' Repair a library left incomplete by an interrupted write
#'
#' For an HDF5 file written by [write_library()], discards the rows past the
#' committed-run count that an append which died part-way left behind (they
#' are ignored by readers until then; the next append also discards them).
#' For an old `.rds` chunk directory (see [disk_library()]) whose
#' `theta.rds` holds more runs than the chunks in `manifest.rds` (an append
#' that died between the two files), cuts `theta.rds` back to the runs the
#' manifest lists and removes chunk files the manifest does not list. Either
#' way the library is left as it was before the interrupted append. The
#' repair takes the writer's lock, so it is refused while a writer is at
#' work; a lock whose writer died (on this host) is taken over, and for an
#' HDF5 file the mark of a writer at work that such a writer leaves in the
#' file (what the HDF5 tool `h5clear` clears) is cleared.
#'
#' @param path An HDF5 file written by [write_library()] or an old `.rds`
#'   chunk directory.
#' @param trust For an `.rds` directory: `TRUE` to read its `.rds` files,
#'   only for a directory you trust (reading an `.rds` file can run code
#'   hidden in it; see the section on security in [disk_library()]).
#' @return A list, invisibly: `path`, the number of `runs` kept and the
#'   number `dropped`; a message reports them.
#' @seealso [write_library()], [hdf5_library()], [disk_library()]
#' @examples
#' if (requireNamespace("hdf5r", quietly = TRUE)) {
#'   ex <- griddy_example()
#'   file <- tempfile(fileext = ".h5")
#'   write_library(ex$library, file)
#'   repair_library(file) # nothing to repair
#'   unlink(file)
#' }
#' @export
repair_library <- function(path, trust = FALSE) {
  path <- assert_string(path, "path")
  trust <- assert_flag(trust, "trust")
  if (!file.exists(path)) {
    griddy_abort("`path` (", path, ") does not exist.")
  }
  out <- if (dir.exists(path)) repair_rds_library(path, trust) else repair_h5_library(path)
  message("The library in ", out$path, " holds ", out$runs, " runs; ",
          if (out$dropped > 0L) paste0(out$dropped, " uncommitted run(s) discarded.")
          else "nothing to repair.")
  invisible(out)
}

# ---- the library interface, HDF5 (see library_interface.R) -----------------

# Runs first..last of the outputs, one read.
h5_piece <- function(library, first, last) {
  structure(list(file = library$file, outputs = library$outputs, layout = library$layout,
                 first = as.integer(first), last = as.integer(last), n_out = library$n_out),
            class = "h5_piece")
}

h5_pieces <- function(library) {
  starts <- seq(1L, library$n_runs, by = library$chunk_size)
  ends <- pmin(starts + library$chunk_size - 1L, library$n_runs)
  list(pieces = Map(h5_piece, list(library), starts, ends), rows = ends - starts + 1L)
}

#' @exportS3Method
read_piece.h5_piece <- function(piece) {
  h5 <- h5_open(piece$file, "r")
  on.exit(h5_close(h5), add = TRUE)
  h5_read_runs(h5, piece, seq.int(piece$first, piece$last))
}

# Rows `runs` (increasing) of the outputs dataset of an open file, as a
# runs x outputs matrix checked against the library's dimensions.
h5_read_runs <- function(h5, piece, runs) {
  where <- paste0("Dataset '", piece$outputs, "' of ", piece$file)
  if (!h5$exists(piece$outputs)) {
    griddy_abort(where, " no longer exists: the file changed after it was opened.",
                 class = "library")
  }
  ds <- h5[[piece$outputs]]
  on.exit(ds$close(), add = TRUE)
  dims <- rev(ds$dims)
  if (length(dims) == 1L) dims <- c(dims, 1L)
  n_ext <- if (piece$layout == "runs_first") dims[1] else dims[2]
  n_out <- if (piece$layout == "runs_first") dims[2] else dims[1]
  if (n_out != piece$n_out || n_ext < max(runs)) {
    griddy_abort(where, " is now ", paste(dims, collapse = " x "), " (as h5dump shows it) ",
                 "but the library needs ", max(runs), " runs of ", piece$n_out, " outputs (",
                 piece$layout, "): the file changed after it was opened; open it again.",
                 class = "library")
  }
  y <- tryCatch({
    if (length(ds$dims) == 1L) {
      matrix(h5_plain(ds$read(args = list(runs))), ncol = 1L)
    } else if (piece$layout == "runs_first") {
      t(h5_plain(ds$read(args = list(seq_len(n_out), runs), drop = FALSE)))
    } else {
      h5_plain(ds$read(args = list(runs, seq_len(n_out)), drop = FALSE))
    }
  }, error = function(e) {
    griddy_abort(where, " cannot be read at runs ", min(runs), " to ", max(runs), ": ",
                 h5_error_summary(e), ".", class = "library")
  })
  if (!is.matrix(y)) y <- matrix(y, nrow = length(runs))
  check_piece(y, length(runs), piece$n_out,
              paste0(where, " (runs ", min(runs), " to ", max(runs), ")"), min(runs))
}

#' @exportS3Method
lib_on_disk.hdf5_library <- function(library) TRUE

#' @exportS3Method
lib_quad_forms.hdf5_library <- function(library, y_field, setup) {
  p <- h5_pieces(library)
  chunked_quad_forms(p$pieces, p$rows, y_field, setup)
}

#' @exportS3Method
lib_outputs.hdf5_library <- function(library, rows = NULL) {
  runs <- lib_check_rows(library, rows)
  wanted <- sort(unique(runs))
  h5 <- h5_open(library$file, "r")
  on.exit(h5_close(h5), add = TRUE)
  out <- matrix(0, length(wanted), library$n_out)
  groups <- split(seq_along(wanted), (wanted - 1L) %/% library$chunk_size)
  for (g in groups) {
    out[g, ] <- h5_read_runs(h5, h5_piece(library, 1L, 1L), wanted[g])
  }
  if (identical(runs, wanted)) out else out[match(runs, wanted), , drop = FALSE]
}

#' @exportS3Method
lib_check_integrity.hdf5_library <- function(library) {
  ok <- is.character(library$file) && length(library$file) == 1L &&
    is.character(library$outputs) && length(library$outputs) == 1L &&
    isTRUE(library$layout %in% c("runs_first", "runs_last")) &&
    is.numeric(library$n_runs) && length(library$n_runs) == 1L &&
    is.numeric(library$n_out) && length(library$n_out) == 1L &&
    is.numeric(library$chunk_size) && length(library$chunk_size) == 1L &&
    isTRUE(library$chunk_size >= 1)
  if (!ok) {
    griddy_abort("The hdf5_library has been edited: `file`, `outputs`, `layout`, `n_runs`, ",
                 "`n_out` and `chunk_size` must be as hdf5_library() made them. Open it ",
                 "again with hdf5_library().", class = "shape")
  }
  check_library_parts(library, library$n_runs, library$n_out, "hdf5_library",
                      fix = "Open it again with hdf5_library().")
  if (!file.exists(library$file)) {
    griddy_abort("The file of the hdf5_library, ", library$file, ", no longer exists.",
                 class = "library")
  }
  invisible(library)
}

# ---- reading HDF5 ----------------------------------------------------------

# Opens a file, turning HDF5's error stack into one sentence. HDF5 refuses
# to open a file that another process has open for writing, and a writer a
# file that others are reading. Both try again for up to `wait` seconds: a
# writer ("r+", which holds griddy's lock, so the others are readers, each
# open for the moment of a read), so that someone looking at a campaign's
# library does not stop the campaign; a reader, for the moments a writer
# holds the file alone (see below).
#
# Single writer, multiple readers (SWMR). Files written by this version use
# HDF5's latest format (superblock version 3), and appends open them in SWMR
# mode (`swmr = TRUE`): readers then open the file while the writer appends
# (HDF5 keeps the file's structure readable at every moment of the write)
# and read the committed runs only, so a reader is never kept waiting by a
# campaign. A plain reader finds such a file marked as open for writing and
# is opened again as an SWMR reader. Files in the older format (superblock
# version 0, written by earlier versions) are appended to as before, and
# their readers are refused for the moment of an append.
h5_open <- function(file, mode, wait = 60, swmr = FALSE, clear = FALSE) {
  start <- proc.time()[["elapsed"]]
  pause <- 0.02
  # SWMR readers take no lock of HDF5's, so they never keep a writer waiting
  if (mode == "r" && !clear) swmr <- h5_swmr_capable(file)
  repeat {
    h5 <- tryCatch(h5_open_once(file, mode, swmr, clear), error = function(e) e)
    if (inherits(h5, "error") && mode == "r" && h5_open_for_write(h5)) {
      h5 <- tryCatch(h5_open_once(file, mode, swmr = TRUE), error = function(e) e)
    }
    if (!inherits(h5, "error")) return(h5)
    waited <- proc.time()[["elapsed"]] - start
    # a reader also waits while a plain (not SWMR) writer has the file: for
    # the moment griddy records failed runs or cuts uncommitted ones
    busy <- grepl("unable to lock", conditionMessage(h5), ignore.case = TRUE) ||
      (mode == "r" && h5_open_for_write(h5))
    if (!busy || waited >= wait) {
      h5_open_failed(file, mode, h5, waited)
    }
    Sys.sleep(min(pause, wait - waited))
    pause <- min(1, pause * 1.5)
  }
}

# HDF5's refusal of a file whose superblock says a writer has it open (or
# had it open and died: see h5_recover()).
h5_open_for_write <- function(e) {
  grepl("already open for write", conditionMessage(e), fixed = TRUE)
}

# `swmr`: an SWMR reader ("r") or writer ("r+"). `clear`: clear the
# superblock's mark of a writer at work (what the tool h5clear does), for a
# file whose writer died. "w" creates a file in the latest format.
h5_open_once <- function(file, mode, swmr = FALSE, clear = FALSE) {
  # closing the file closes every object opened in it (H5F_CLOSE_STRONG):
  # faster than hdf5r's close_all(), which runs the garbage collector
  fapl <- hdf5r::H5P_FILE_ACCESS$new()
  # hdf5r wraps these HDF5 routines without R methods for them: call its
  # registered routines, found at run time
  .Call(h5_routine("R_H5Pset_fclose_degree"), fapl$id, hdf5r::h5const$H5F_CLOSE_STRONG)
  if (!h5_has_swmr()) {
    # HDF5 before 1.10: the older format, no SWMR, no marks to clear
    return(hdf5r::H5File$new(file, mode, file_access_pl = fapl))
  }
  if (mode == "w" || (swmr && mode == "r+")) {
    .Call(h5_routine("R_H5Pset_libver_bounds"), fapl$id, hdf5r::h5const$H5F_LIBVER_V110,
          hdf5r::h5const$H5F_LIBVER_V110)
  }
  if (clear) {
    # a property HDF5 registers for h5clear ("clear_status_flags", a bool)
    .Call(h5_routine("R_H5Pset"), fapl$id, "clear_status_flags", as.raw(c(1, 0, 0, 0)))
  }
  if (!swmr) return(hdf5r::H5File$new(file, mode, file_access_pl = fapl))
  const <- hdf5r::h5const
  flags <- if (mode == "r") {
    bitwOr(const$H5F_ACC_RDONLY, const$H5F_ACC_SWMR_READ)
  } else {
    bitwOr(const$H5F_ACC_RDWR, const$H5F_ACC_SWMR_WRITE)
  }
  if (mode == "r") {
    # an SWMR reader needs no lock of HDF5's (the SWMR protocol keeps what it
    # reads consistent), and holding one would keep the writer waiting
    withr::local_envvar(HDF5_USE_FILE_LOCKING = "FALSE")
  }
  fid <- .Call(h5_routine("R_H5Fopen"), normalizePath(file), flags, fapl$id)$return_val
  hdf5r::H5File$new(id = fid)
}

# Whether the HDF5 library under hdf5r has SWMR (1.10 or later).
h5_has_swmr <- function() {
  utils::compareVersion(hdf5r::h5version(verbose = FALSE), "1.10.0") >= 0
}

# Whether a file is in the format SWMR needs (superblock version 3 or
# later; the version is the byte after the 8-byte signature).
h5_swmr_capable <- function(file) {
  if (!h5_has_swmr()) return(FALSE)
  head <- tryCatch(readBin(file, "raw", 9L), error = function(e) raw(0))
  length(head) == 9L && as.integer(head[9L]) >= 3L
}

h5_open_failed <- function(file, mode, e, waited) {
  msg <- conditionMessage(e)
  if (!file.exists(file)) {
    griddy_abort("The HDF5 file ", file, " does not exist.", class = "library")
  }
  if (h5_open_for_write(e) && mode == "r") {
    griddy_abort("The HDF5 file ", file, " is marked as open for writing (not in SWMR ",
                 "mode) by another process, and was still after ", round(waited), " s. If ",
                 "no process is writing it (a writer died), repair_library(\"", file,
                 "\") clears the mark.", class = "lock")
  }
  if (h5_open_for_write(e) && mode != "r") {
    griddy_abort("The HDF5 file ", file, " is marked as open for writing by a process ",
                 "other than a griddy writer (none holds its lock), or by one that died ",
                 "without its lock. If no process is writing it, repair_library(\"", file,
                 "\") clears the mark and discards any uncommitted runs.", class = "lock")
  }
  if (grepl("unable to lock", msg, ignore.case = TRUE)) {
    if (mode != "r") {
      griddy_abort("The HDF5 file ", file, " is held open by another process (a reader) and ",
                   "HDF5 refuses to write it meanwhile; it still was after ", round(waited),
                   " s. Close the other sessions' views of it and run again.", class = "lock")
    }
    lock <- lock_path(file)
    griddy_abort("The HDF5 file ", file, " is open for writing by another process",
                 if (dir.exists(lock)) paste0(" (the lock ", lock, " is held by ",
                                              lock_who(lock_owner(lock)), ")"),
                 ", and HDF5 refuses to open it meanwhile; it still did after ",
                 round(waited), " s (a file written by an earlier version of griddy, in ",
                 "HDF5's older format, is held for a whole append; ",
                 "write_library(hdf5_library(file), new_file) converts it). Try again ",
                 "when that write has finished.",
                 class = "lock")
  }
  griddy_abort("The file ", file, " cannot be opened as an HDF5 file",
               if (mode != "r") " for writing", ": ", h5_error_summary(e), ".",
               class = "library")
}

h5_routine <- function(name) utils::getFromNamespace(name, "hdf5r")

h5_close <- function(h5) if (h5$is_valid) h5$close()

# The innermost HDF5 error of an hdf5r error message.
h5_error_summary <- function(e) {
  msg <- conditionMessage(e)
  minor <- regmatches(msg, gregexpr("minor: [^\n]*", msg))[[1]]
  if (length(minor) > 0L) {
    return(tolower(sub("^minor: ", "", minor[length(minor)])))
  }
  sub("\n.*$", "", msg)
}

h5_dataset <- function(h5, name, arg, file) {
  if (!is.character(name) || length(name) != 1L || is.na(name) || !nzchar(name)) {
    griddy_abort("`", arg, "` must name a dataset in the file; received ",
                 paste(format(name), collapse = ", "), ".")
  }
  ok <- tryCatch(h5$exists(name) && inherits(h5[[name]], "H5D"), error = function(e) FALSE)
  if (!ok) {
    have <- tryCatch({
      l <- h5$ls(recursive = TRUE)
      l$name[l$obj_type == "H5I_DATASET"]
    }, error = function(e) character(0))
    griddy_abort("`", arg, "`: ", file, " has no dataset '", name, "'; its datasets are ",
                 if (length(have)) show_some(paste0("'", have, "'"), 10) else "none", ".")
  }
  h5[[name]]
}

# Dimensions in HDF5's order (as h5dump shows them) -> "runs_first" or
# "runs_last", checked against the known number of runs and of the other
# dimension (either may be NULL when unknown).
h5_orient <- function(dims, layout, n_runs, n_other, arg, name, other, file) {
  fits <- function(runs_dim) {
    (is.null(n_runs) || dims[runs_dim] == n_runs) &&
      (is.null(n_other) || dims[3L - runs_dim] == n_other)
  }
  shown <- paste0("dataset '", name, "' in ", file, " is ", paste(dims, collapse = " x "),
                  " (in HDF5's order, as h5dump and h5py show it)")
  expect <- paste0(if (!is.null(n_runs)) paste0(n_runs, " runs"),
                   if (!is.null(n_runs) && !is.null(n_other)) " and ",
                   if (!is.null(n_other)) paste0(n_other, " ", other))
  if (layout != "auto") {
    if (!fits(if (layout == "runs_first") 1L else 2L)) {
      griddy_abort("`", arg, "`: ", shown, ", which does not fit layout \"", layout,
                   "\" with ", expect, ".", class = "shape")
    }
    return(layout)
  }
  ok <- c(runs_first = fits(1L), runs_last = fits(2L))
  if (all(ok)) {
    griddy_abort("`", arg, "`: ", shown, ": the orientation is ambiguous, since either ",
                 "dimension could be the runs", if (nzchar(expect)) paste0(" (", expect, ")"),
                 ". Give `layout = \"runs_first\"` (runs x ", other, ", as h5py writes) or ",
                 "\"runs_last\" (", other, " x runs, as R, MATLAB or Fortran write).",
                 class = "shape")
  }
  if (!any(ok)) {
    griddy_abort("`", arg, "`: ", shown, ", but neither dimension fits ", expect, ".",
                 class = "shape")
  }
  names(ok)[ok]
}

# A table dataset (theta or x) as a numeric matrix with column names, one row
# per entry (run or setting).
# Only the first `max_rows` rows are validated and kept (a library written by
# write_library() may hold uncommitted rows, whose contents are undefined);
# attribute "rows_stored" says how many the dataset holds.
h5_read_table <- function(ds, names, layout, arg, name, file, one_d_name = NULL,
                          max_rows = NULL) {
  first_rows <- function(m) {
    stored <- nrow(m)
    if (!is.null(max_rows) && stored > max_rows) m <- m[seq_len(max_rows), , drop = FALSE]
    structure(as_numeric_matrix(m, arg), rows_stored = stored)
  }
  type <- ds$get_type()
  cls <- as.character(type$get_class())
  dims <- rev(ds$dims)
  h5_check_stored(ds, arg, name, file)
  if (cls == "H5T_COMPOUND") {
    tab <- ds$read()
    if (!is.data.frame(tab)) tab <- as.data.frame(tab)
    tab[] <- lapply(tab, h5_plain)
    if (!is.null(names)) {
      missing <- setdiff(names, base::names(tab))
      if (length(missing) > 0L) {
        griddy_abort("`theta_names`: dataset '", name, "' in ", file, " has no field(s) ",
                     show_some(missing), "; its fields are ", show_some(base::names(tab)), ".")
      }
      tab <- tab[names]
    }
    text <- names(tab)[vapply(tab, is.character, NA)]
    if (length(text) > 0L) {
      griddy_abort("`", arg, "`: dataset '", name, "' in ", file, " has text field(s) ",
                   show_some(text), ", which griddy does not read as ", arg, " (it reads ",
                   "numbers only)", if (arg == "theta") paste0(
                     "; give `theta_names` to select the numeric fields, e.g. theta_names = ",
                     "c(", paste0("\"", setdiff(names(tab), text), "\"", collapse = ", "), ")"),
                   ".", class = "unsupported")
    }
    return(first_rows(tab))
  }
  if (cls == "H5T_STRING") {
    v <- h5_strings_as_numbers(ds, arg, name, file)
    if (is.null(names)) names <- h5_names_attr(ds)
    if (is.null(names)) names <- one_d_name
    if (is.null(dim(v)) && length(names) == 1L) {
      return(first_rows(matrix(v, ncol = 1L, dimnames = list(NULL, names))))
    }
    griddy_abort("`", arg, "`: dataset '", name, "' in ", file, " holds numbers as text; ",
                 "griddy reads them for a one-dimensional dataset with one name (give ",
                 "`theta_names`), not for this one (", paste(rev(ds$dims), collapse = " x "),
                 "). Store the values as numbers.", class = "unsupported")
  }
  if (!cls %in% c("H5T_FLOAT", "H5T_INTEGER")) {
    griddy_abort("`", arg, "`: dataset '", name, "' in ", file, " holds ",
                 h5_class_words(cls), ", which griddy does not read as ", arg, ": it must ",
                 "be numeric or compound (one numeric field per column).",
                 class = "unsupported")
  }
  if (is.null(names)) names <- h5_names_attr(ds)
  if (length(dims) == 1L) {
    if (is.null(names)) names <- one_d_name
    if (length(names) != 1L) {
      griddy_abort("`", arg, "`: dataset '", name, "' in ", file, " is one-dimensional (one ",
                   "column) but ", if (is.null(names)) "has no name for it: give `theta_names`"
                   else paste0(length(names), " names were given: ", show_some(names)), ".")
    }
    v <- matrix(h5_plain(ds$read()), ncol = 1L, dimnames = list(NULL, names))
    return(first_rows(v))
  }
  if (length(dims) != 2L) {
    griddy_abort("`", arg, "`: dataset '", name, "' in ", file, " must have one or two ",
                 "dimensions; it has ", length(dims), ".")
  }
  if (is.null(names)) {
    griddy_abort("`", arg, "`: dataset '", name, "' in ", file, " is a numeric array ",
                 "without column names: give them",
                 if (arg == "theta") " with `theta_names`" else
                   " by passing `x` as a data.frame", ", or store them in an attribute ",
                 "'names' of the dataset.")
  }
  orient <- h5_orient(dims, layout, NULL, length(names), arg, name,
                      if (arg == "theta") "parameters (names)" else "columns (names)", file)
  v <- h5_plain(ds$read(drop = FALSE))
  dim(v) <- ds$dims
  if (orient == "runs_first") v <- t(v)
  colnames(v) <- names
  first_rows(v)
}

# A dataset's dimensions are only a claim: a file of a few kB can declare
# 10^9 runs that were never written (HDF5 allocates chunks as they are
# written, and reads unwritten ones as fill values), and reading it would
# allocate the claimed size. Refuse, before any read, a dataset whose
# claimed size exceeds what it stores by more than compression could
# explain (deflate's limit is about 1032:1; a bound of 1100 leaves room).
# Small datasets (under 1 MB) are read as they are.
h5_check_stored <- function(ds, arg, name, file, max_ratio = 1100) {
  type <- ds$get_type()
  # variable-length data (strings) have no fixed size to compare: their
  # readers check what they read
  if (as.character(type$get_class()) %in% c("H5T_STRING", "H5T_VLEN")) {
    return(invisible(ds))
  }
  claimed <- prod(as.double(ds$dims)) * type$get_size()
  if (!is.finite(claimed)) return(invisible(ds))
  if (claimed <= 2^20) return(invisible(ds))
  stored <- as.double(ds$get_storage_size())
  if (claimed <= max_ratio * stored) return(invisible(ds))
  size <- function(b) format(structure(b, class = "object_size"), units = "auto",
                             standard = "SI")
  dims <- format(as.double(rev(ds$dims)), big.mark = ",", scientific = FALSE, trim = TRUE)
  griddy_abort("`", arg, "`: dataset '", name, "' in ", file, " claims ",
               paste(dims, collapse = " x "),
               " entries (", size(claimed), ") but stores ", size(stored), " (the file is ",
               size(as.double(file.size(file))), "): its dimensions were written without its ",
               "data, so the file is damaged or not a library. Nothing was read.",
               class = "library")
}

h5_names_attr <- function(ds) {
  for (a in c("names", "column_names")) {
    if (ds$attr_exists(a)) {
      v <- hdf5r::h5attr(ds, a)
      if (is.character(v)) return(as.vector(v))
    }
  }
  NULL
}

h5_read_vector <- function(ds, arg, name, file) {
  h5_check_stored(ds, arg, name, file)
  if (length(ds$dims) != 1L && !(length(ds$dims) == 2L && min(ds$dims) == 1L)) {
    griddy_abort("`", arg, "`: dataset '", name, "' in ", file, " must be one-dimensional; ",
                 "it is ", paste(rev(ds$dims), collapse = " x "), ".")
  }
  if (as.character(ds$get_type()$get_class()) == "H5T_STRING") {
    return(as.vector(h5_strings_as_numbers(ds, arg, name, file)))
  }
  as.vector(h5_plain(ds$read()))
}

# A string dataset (what h5py writes for text, or hdf5r for a character
# vector) read as numbers when every entry is one (numbers kept as text by
# a pipeline); otherwise an error of class `griddy_error_unsupported` naming
# an entry that is not.
h5_strings_as_numbers <- function(ds, arg, name, file) {
  v <- ds$read()
  num <- suppressWarnings(as.numeric(trimws(v)))
  bad <- which(is.na(num))
  if (length(bad) > 0L) {
    griddy_abort("`", arg, "`: dataset '", name, "' in ", file, " holds text (an HDF5 ",
                 "string dataset), and not numbers written as text: entry ", bad[1], " is \"",
                 substr(v[bad[1]], 1L, 40L), "\". griddy reads ", arg, " as numbers only; ",
                 "store them as numbers", if (arg == "theta") " (or a compound dataset with ",
                 if (arg == "theta") "one numeric field per parameter)", ".",
                 class = "unsupported")
  }
  dim(num) <- dim(v)
  num
}

h5_class_words <- function(cls) {
  switch(cls, H5T_STRING = "text (an HDF5 string dataset)",
         H5T_COMPOUND = "records (a compound dataset)",
         paste0("data of HDF5 class ", cls))
}

# 64-bit integers (what NumPy writes by default) arrive as bit64's integer64.
h5_plain <- function(v) {
  if (inherits(v, "integer64")) {
    d <- dim(v)
    v <- as.double(v)
    dim(v) <- d
  }
  v
}

as_layout <- function(layout) {
  choices <- c("auto", "runs_first", "runs_last")
  if (!is.character(layout) || length(layout) < 1L || anyNA(layout) ||
      !all(layout %in% choices) ||
      (length(layout) > 1L && (is.null(names(layout)) ||
                                 !all(names(layout) %in% c("theta", "outputs", "x"))))) {
    griddy_abort("`layout` must be \"auto\", \"runs_first\" or \"runs_last\", or a named ",
                 "vector of these with names among theta, outputs and x; received ",
                 paste(format(layout), collapse = ", "), ".")
  }
  out <- c(theta = "auto", outputs = "auto", x = "auto")
  if (length(layout) == 1L && is.null(names(layout))) {
    out[] <- layout
  } else {
    out[names(layout)] <- layout
  }
  out
}

# Whether the file was written by write_library(), and its committed runs.
h5_griddy_meta <- function(h5) {
  if (!h5$attr_exists("griddy_format")) {
    return(list(griddy = FALSE, n_runs = NA))
  }
  if (!h5$attr_exists("griddy_n_runs")) {
    griddy_abort(h5$get_filename(), " was written by write_library() but has no ",
                 "committed-run count (attribute griddy_n_runs): it is damaged.",
                 class = "library")
  }
  n_runs <- hdf5r::h5attr(h5, "griddy_n_runs")
  ok <- is.numeric(n_runs) && length(n_runs) == 1L && is.finite(n_runs) && n_runs >= 0 &&
    n_runs == round(n_runs) && n_runs <= .Machine$integer.max
  if (!ok) {
    griddy_abort(h5$get_filename(), " is damaged: its committed-run count (attribute ",
                 "griddy_n_runs) must be one whole number of runs; it is ",
                 paste(format(n_runs), collapse = ", "), if (is.character(n_runs)) " (text)",
                 ". Rewrite the library from the simulator's outputs, or set the attribute ",
                 "to the number of runs written.", class = "library")
  }
  list(griddy = TRUE, n_runs = as.integer(n_runs))
}

# Rows past the committed count: an append at work (a live writer holds the
# lock; reading the committed runs meanwhile is what readers are meant to
# do, so nothing is said), or the leftovers of one that died.
h5_warn_uncommitted <- function(file, n_runs, n_ext) {
  lock <- lock_path(file)
  if (dir.exists(lock) && !lock_is_stale(lock_owner(lock))) return(invisible())
  griddy_warn(file, " holds ", n_ext - n_runs, " uncommitted run(s) past its ", n_runs,
              " committed runs, left by an append that did not finish; griddy uses the ",
              "committed runs. Run repair_library(\"", file, "\") to discard them",
              if (dir.exists(lock)) " (it also takes over the dead writer's lock)",
              "; the next write_library(append = TRUE) or simulate_library() on it also does.",
              class = "library")
}

# ---- writing HDF5 ----------------------------------------------------------

# The empty library (0 runs, committed), built under a temporary name and
# renamed into place: the file exists whole or not at all.
h5_create_library <- function(library, file, chunk_size) {
  n_out <- lib_n_out(library)
  theta <- lib_theta(library)
  p <- ncol(theta)
  if (is.null(chunk_size)) chunk_size <- max(1L, as.integer(floor(2^20 / (8 * n_out))))
  tmp <- paste0(file, ".new-", Sys.getpid())
  unlink(tmp)
  h5 <- h5_open(tmp, "w")
  ok <- FALSE
  open <- list()
  on.exit({
    h5_close_all(open, h5)
    if (!ok) unlink(tmp)
  }, add = TRUE)
  open$theta <- h5_extendable(h5, "theta", p, chunk_size)
  hdf5r::h5attr(open$theta, "names") <- names(theta)
  open$y <- h5_extendable(h5, "y", n_out, chunk_size)
  if (!is.null(lib_x(library))) {
    h5[["x"]] <- as.data.frame(lapply(lib_x(library), as.double))
  }
  h5[["t"]] <- lib_t(library)
  hdf5r::h5attr(h5, "griddy_format") <- 1L
  hdf5r::h5attr(h5, "griddy_n_runs") <- 0
  hdf5r::h5attr(h5, "griddy_note") <- paste(
    "Simulation library written by the R package griddy: theta (runs x parameters, names in",
    "its attribute 'names') and y (runs x outputs, in blocks by x setting) in R's",
    "column-major order, so h5py shows them transposed; x (settings, compound) and t",
    "(coordinates); only the first griddy_n_runs runs are committed.")
  h5_close_all(open, h5)
  if (!file.rename(tmp, file)) {
    griddy_abort("Cannot create ", file, " (renaming ", tmp, " failed).", class = "library")
  }
  ok <- TRUE
  invisible(file)
}

# A double dataset of 0 runs x `n` columns (R order), extendable in runs.
h5_extendable <- function(h5, name, n, chunk_size) {
  cp <- hdf5r::H5P_DATASET_CREATE$new()
  cp$set_chunk(c(chunk_size, n))
  # no fill values: writing them costs as much as writing the data
  cp$set_fill_time(hdf5r::h5const$H5D_FILL_TIME_NEVER)
  h5$create_dataset(name, space = hdf5r::H5S$new(dims = c(0, n), maxdims = c(Inf, n)),
                    dtype = hdf5r::h5types$H5T_NATIVE_DOUBLE, dataset_create_pl = cp,
                    chunk_dims = NULL)
}

# Appends the runs of `library` to a file written by write_library(): new
# rows first, the committed-run count last. The caller holds the lock. The
# append is made in SWMR mode when the file's format allows it, so readers
# are not refused meanwhile; rows an earlier append left uncommitted are cut
# first, outside SWMR mode (HDF5 does not shrink datasets in it).
h5_append_runs <- function(library, file) {
  dropped <- h5_drop_before_append(file)
  # the runs, and room for a new chunk of each dataset the last one opens
  h5_reserve_space(file, 8 * nrow(lib_theta(library)) * (ncol(lib_theta(library)) +
                                                        lib_n_out(library)) +
                     2 * dropped$chunk_bytes)
  h5 <- h5_open(file, "r+", swmr = h5_swmr_capable(file))
  open <- list()
  # every handle closed, datasets before the file, even when a write failed
  # (hdf5r's finalizers of handles left open on a failed file crash R)
  on.exit(h5_close_all(open, h5), add = TRUE)
  done <- FALSE
  # a failed write (a full disk) leaves data HDF5 cannot flush: the new rows
  # are cut at once, which drops it, so the file can be closed
  on.exit(if (!done) h5_cut_back(open, n0), add = TRUE, after = FALSE)
  n0 <- NA
  meta <- h5_griddy_meta(h5)
  if (dropped$n > 0L) {
    griddy_warn("Discarded ", dropped$n, " uncommitted run(s) that an interrupted append ",
                "left in ", file, "; appending after its ", meta$n_runs, " committed runs.",
                class = "library")
  }
  open <- list(theta_ds = h5[["theta"]], y_ds = h5[["y"]], t_ds = h5[["t"]])
  if (h5$exists("x")) open$x_ds <- h5[["x"]]
  n0 <- meta$n_runs
  new_theta <- as.matrix(lib_theta(library))
  theta_names <- h5_check_same_library(open, library, new_theta)
  old_theta <- if (n0 > 0L) open$theta_ds$read(args = list(seq_len(n0), seq_len(ncol(new_theta))),
                                                 drop = FALSE)
  all_theta <- rbind(old_theta, new_theta)
  colnames(all_theta) <- theta_names
  assert_distinct_runs(all_theta)
  k <- nrow(new_theta)
  n_out <- lib_n_out(library)
  open$theta_ds$set_extent(c(n0 + k, ncol(new_theta)))
  open$y_ds$set_extent(c(n0 + k, n_out))
  h5$flush()
  write_hook("extended")
  open$theta_ds$write(args = list(n0 + seq_len(k), seq_len(ncol(new_theta))), new_theta)
  piece <- max(1L, as.integer(floor(2^23 / n_out)))
  for (start in seq(1L, k, by = piece)) {
    rows <- seq.int(start, min(k, start + piece - 1L))
    open$y_ds$write(args = list(n0 + rows, seq_len(n_out)), lib_outputs(library, rows))
    write_hook("piece")
  }
  h5$flush()
  write_hook("rows_written")
  open$count <- h5$attr_open("griddy_n_runs")
  open$count$write(as.double(n0 + k))
  h5$flush()
  done <- TRUE
  write_hook("committed")
  invisible(n0 + k)
}

h5_cut_back <- function(open, n0) {
  if (is.na(n0)) return(invisible())
  for (ds in open[c("theta_ds", "y_ds")]) {
    try(if (ds$dims[1] > n0) ds$set_extent(c(n0, ds$dims[2])), silent = TRUE)
  }
}

# A full disk met by HDF5 in the middle of a write is hard to leave cleanly:
# the file cannot be closed (HDF5 cannot flush what it holds), and HDF5 1.10
# then crashes R at exit. So the room an append needs (its runs, plus a
# margin for partly filled chunks and the index) is tried first, outside
# HDF5: zeros written past the end of the file, which is then cut back. A
# device that is full, a quota or a file-size limit (ulimit -f) is met
# there, and the append stops with a `griddy_error_disk` before the file is
# touched.
h5_reserve_space <- function(file, bytes) {
  size <- file.size(file)
  bytes <- ceiling(1.1 * bytes) + 2^16
  con <- file(file, "r+b")
  on.exit(close(con), add = TRUE)
  block <- raw(min(bytes, 2^22))
  failed <- tryCatch({
    seek(con, size, rw = "write")
    for (i in seq_len(ceiling(bytes / length(block)))) writeBin(block, con)
    flush(con)
    NULL
  }, error = conditionMessage, warning = conditionMessage)
  seek(con, size, rw = "write")
  truncate(con)
  if (!is.null(failed)) {
    need <- format(structure(bytes, class = "object_size"), units = "auto", standard = "SI")
    griddy_abort("Writing ", file, " failed: the disk is full (or the file reached a size ",
                 "limit, such as a quota or ulimit -f): the append needs about ", need,
                 " more and the system refused them (", failed, "). Nothing was written; ",
                 "the library keeps its committed runs. Free some space and write the runs ",
                 "again.", class = "disk")
  }
  invisible(file)
}

# Refuses to append a library whose parameters, x or t differ from the
# file's (`open`: the file's datasets); returns the file's parameter names.
h5_check_same_library <- function(open, library, new_theta) {
  theta_names <- h5_names_attr(open$theta_ds)
  same <- function(a, b) length(a) == length(b) && all(as.double(a) == as.double(b))
  stored_x <- if (!is.null(open$x_ds)) as.data.frame(open$x_ds$read()) else NULL
  new_x <- lib_x(library)
  stored_t <- as.vector(open$t_ds$read())
  differs <- c(
    parameters = !identical(theta_names, colnames(new_theta)),
    `settings x` = !identical(is.null(stored_x), is.null(new_x)) ||
      (!is.null(new_x) && (!identical(names(stored_x), names(new_x)) ||
                             nrow(stored_x) != nrow(new_x) ||
                             !same(as.matrix(stored_x), as.matrix(new_x)))),
    `coordinates t` = !same(stored_t, lib_t(library)))
  if (any(differs)) {
    griddy_abort("`library` must have the parameters, settings `x` and coordinates `t` of ",
                 "the library in `file` to be appended to it; its ",
                 paste(names(differs)[differs], collapse = " and "), " differ. The file has ",
                 "parameters ", show_some(theta_names), ", ",
                 if (is.null(stored_x)) "one setting" else paste0(nrow(stored_x), " setting(s)"),
                 " and ", length(stored_t), " coordinate(s) t; `library` has ",
                 show_some(colnames(new_theta)), ", ",
                 if (is.null(new_x)) "one setting" else paste0(nrow(new_x), " setting(s)"),
                 " and ", length(lib_t(library)), ".")
  }
  theta_names
}

# Before an append: checks the file is griddy's and cuts the rows an
# earlier append left uncommitted (in a plain, short, open).
h5_drop_before_append <- function(file) {
  h5 <- h5_open(file, "r")
  meta <- tryCatch(h5_griddy_meta(h5), error = function(e) {
    h5_close(h5)
    stop(e)
  })
  n_ext <- if (meta$griddy) max(h5[["theta"]]$dims[1], h5[["y"]]$dims[1])
  chunk_bytes <- if (meta$griddy) {
    8 * (prod(h5[["theta"]]$chunk_dims) + prod(h5[["y"]]$chunk_dims))
  }
  h5_close(h5)
  if (!meta$griddy) {
    griddy_abort("`file` (", file, ") was not written by write_library(): griddy appends ",
                 "only to its own files (a file from another pipeline is read as it is by ",
                 "hdf5_library()).")
  }
  if (n_ext <= meta$n_runs) return(list(n = 0L, chunk_bytes = chunk_bytes))
  h5 <- h5_open(file, "r+")
  on.exit(h5_close(h5), add = TRUE)
  list(n = h5_drop_uncommitted(h5, meta$n_runs), chunk_bytes = chunk_bytes)
}

# Closes hdf5r handles (datasets, attributes), then the file, each once and
# whatever the others do; then lets the garbage collector run the handles'
# finalizers while nothing is left for them to close.
h5_close_all <- function(handles, h5) {
  for (obj in c(rev(handles), h5)) {
    if (!is.null(obj)) tryCatch(if (obj$is_valid) obj$close(), error = function(e) h5_forget(obj))
  }
  invisible(gc(verbose = FALSE))
}

# An hdf5r handle whose close failed (a write that could not be flushed) is
# still marked open, and its finalizer closes it again, which crashes R in
# HDF5 (the object is half freed). It is marked closed instead: hdf5r keeps
# the mark in the handle's private field `pid` (the handle's id is dropped
# from hdf5r's count, as its close() does).
h5_forget <- function(obj) {
  priv <- obj$.__enclos_env__$private
  id <- tryCatch(priv$pid$id, error = function(e) NULL)
  if (length(id) == 1L && !is.na(id)) {
    try(utils::getFromNamespace("decr_count", "hdf5r")(id), silent = TRUE)
  }
  priv$pid <- NA
  invisible(obj)
}

# The committed runs of a file written by write_library(), read without the
# checks of a library (it may hold one run, or none): list(theta = a
# data.frame, n_out). NULL when the file does not exist.
h5_committed_theta <- function(file) {
  h5_recover_dead_writer(file)
  if (!file.exists(file)) return(NULL)
  h5 <- h5_open(file, "r")
  on.exit(h5_close(h5), add = TRUE)
  meta <- h5_griddy_meta(h5)
  if (!meta$griddy) {
    griddy_abort("`file` (", file, ") was not written by write_library(): griddy adds ",
                 "runs only to its own files.", class = "library")
  }
  ds <- h5[["theta"]]
  names <- h5_names_attr(ds)
  theta <- if (meta$n_runs > 0L) {
    ds$read(args = list(seq_len(meta$n_runs), seq_along(names)), drop = FALSE)
  } else {
    matrix(0, 0L, length(names))
  }
  colnames(theta) <- names
  list(theta = as.data.frame(theta), n_out = as.integer(h5[["y"]]$dims[2]))
}

repair_h5_library <- function(file) {
  require_package("hdf5r", "to repair an HDF5 library")
  file <- normalizePath(file)
  token <- library_lock(file, "library file", recover = function() "repairing it.")
  on.exit(library_unlock(token), add = TRUE)
  # under the lock no griddy writer is at work: a writer's mark left in the
  # superblock is one that died, and is cleared
  h5 <- h5_open(file, "r+", clear = TRUE)
  on.exit(h5_close(h5), add = TRUE, after = FALSE)
  meta <- h5_griddy_meta(h5)
  if (!meta$griddy) {
    griddy_abort("`path` (", file, ") was not written by write_library(): there is no ",
                 "committed-run count to repair to (hdf5_library() reads such files as they ",
                 "are).")
  }
  list(path = file, runs = meta$n_runs, dropped = h5_drop_uncommitted(h5, meta$n_runs))
}

# Cuts the theta and outputs datasets of a write_library() file back to its
# `n_runs` committed runs; returns how many uncommitted runs it dropped.
h5_drop_uncommitted <- function(h5, n_runs) {
  theta_ds <- h5[["theta"]]
  y_ds <- h5[["y"]]
  n_ext <- max(theta_ds$dims[1], y_ds$dims[1])
  if (n_ext > n_runs) {
    theta_ds$set_extent(c(n_runs, theta_ds$dims[2]))
    y_ds$set_extent(c(n_runs, y_ds$dims[2]))
    h5$flush()
  }
  as.integer(max(0L, n_ext - n_runs))
}
