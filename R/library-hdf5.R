# Libraries in HDF5 files, through hdf5r: a reader for files any pipeline
# wrote (hdf5_library()); griddy's own writer, with safe appends
# (write_library(), repair_library()), is in library-hdf5-write.R.
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

# ---- the library interface, HDF5 (see library.R) -----------------

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
