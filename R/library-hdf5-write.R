# Writing libraries to HDF5 files (write_library(), repair_library()):
# griddy's own writer, with safe appends (the file's committed row count is
# written last), a lock per file (library-lock.R) and SWMR appends, so that
# readers (library-hdf5.R) see only committed runs and are never blocked.

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
  # a calling handler: griddy's own errors go on as they are (the handler
  # returns), HDF5's are replaced by the classed one
  withCallingHandlers(expr, error = function(e) {
    if (inherits(e, "griddy_error")) return()
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
  meta <- withCallingHandlers(h5_griddy_meta(h5), error = function(e) h5_close(h5))
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
