# The library interface. Code outside the library files (library_*.R,
# sim_library.R) reads a library only through these functions, never through
# its fields, so that a backend -- in memory, an HDF5 file, an old directory
# of .rds chunks -- is a set of methods. Every backend holds theta, x and t in
# memory (N x p, small) as the list elements `theta`, `x` and `t`; the outputs
# (N x n_x n_t, large) are read on demand.

is_library <- function(library) {
  inherits(library, c("sim_library", "disk_library", "hdf5_library", "refined_library",
                      "emulated_library"))
}

check_library <- function(library, disk = TRUE) {
  if (!inherits(library, "sim_library") && !(disk && is_library(library))) {
    griddy_abort("`library` must be a sim_library (see ?sim_library)",
                 if (disk) paste0(", an hdf5_library (see ?hdf5_library) or a disk_library ",
                                  "(see ?disk_library)"), "; received ",
                 class(library)[1], ".")
  }
  lib_check_integrity(library)
  invisible(library)
}

# Parameter values of the runs (a data.frame, one row per run).
lib_theta <- function(library) library$theta

# Control settings (a data.frame, or NULL for a single setting) and output
# coordinates.
lib_x <- function(library) library$x
lib_t <- function(library) library$t

lib_n_runs <- function(library) nrow(lib_theta(library))
lib_n_x <- function(library) if (is.null(lib_x(library))) 1L else nrow(lib_x(library))
lib_n_t <- function(library) length(lib_t(library))
lib_n_out <- function(library) lib_n_x(library) * lib_n_t(library)

# Outputs of runs `rows` (all runs when NULL), a matrix in the order given,
# blocks by x setting (thesis App. A.1).
lib_outputs <- function(library, rows = NULL) UseMethod("lib_outputs")

# The quadratic forms C (runs x correlation grid points) of `y_field` under
# every grid point of `setup`; see correlation_setup() and misfit_table() in
# grid_posterior.R.
lib_quad_forms <- function(library, y_field, setup) UseMethod("lib_quad_forms")

# Whether the outputs stay on disk (read in chunks when C is computed)
# rather than in memory.
lib_on_disk <- function(library) UseMethod("lib_on_disk")

#' @exportS3Method
lib_on_disk.default <- function(library) FALSE

# Checks that an object, perhaps edited after construction, still fits
# together, so that no inconsistent library reaches C++.
lib_check_integrity <- function(library) UseMethod("lib_check_integrity")

# A row index for lib_outputs(): whole numbers in 1..N.
lib_check_rows <- function(library, rows) {
  n <- lib_n_runs(library)
  if (is.null(rows)) return(seq_len(n))
  if (!is.numeric(rows) || anyNA(rows) || any(rows < 1 | rows > n | rows != round(rows))) {
    griddy_abort("Library rows must be whole numbers in 1..", n, "; received ",
                 show_some(utils::head(rows[is.na(rows) | rows < 1 | rows > n], 5)), ".",
                 class = "shape")
  }
  as.integer(rows)
}

# ---- chunked backends ------------------------------------------------------

# C of a library read in pieces: one plain_quad_forms() call per piece, mapped
# over the future plan's workers in waves of one piece per worker, each wave's
# results copied into C at once, so memory holds C and one wave of pieces.
# `pieces` is a list of read specifications (see read_piece()), `rows` the
# number of runs in each, in library order. Workers need griddy installed,
# and share griddy_threads() between them.
chunked_quad_forms <- function(pieces, rows, y_field, setup) {
  piece_C <- function(piece, y_field, setup, threads) {
    plain_quad_forms(read_piece(piece), y_field, setup, threads)
  }
  environment(piece_C) <- asNamespace("griddy")
  parallel <- requireNamespace("future.apply", quietly = TRUE)
  map <- if (parallel) {
    function(...) future.apply::future_lapply(..., future.seed = NULL,
                                              future.packages = "griddy")
  } else {
    lapply
  }
  per_wave <- if (parallel) max(1L, as.integer(future::nbrOfWorkers())) else 1L
  ends <- cumsum(rows)
  C <- matrix(0, sum(rows), n_grid_points(setup))
  for (wave in split(seq_along(pieces), (seq_along(pieces) - 1L) %/% per_wave)) {
    out <- map(pieces[wave], piece_C, y_field = y_field, setup = setup,
               threads = threads_per_worker(per_wave))
    for (j in seq_along(wave)) {
      k <- wave[j]
      C[ends[k] - rows[k] + seq_len(rows[k]), ] <- out[[j]]
    }
  }
  C
}

# Reads one piece of a chunked library's outputs (runs x outputs, checked
# against the dimensions the library expects): a method per backend.
read_piece <- function(piece) UseMethod("read_piece")

# Checks a piece read from disk before it reaches C++: a double matrix of the
# expected dimensions with finite values. `where` names the file (and dataset);
# `first` is the library row of the piece's first run.
check_piece <- function(y, n_rows, n_out, where, first = 1L) {
  if (!is.matrix(y) || !is.numeric(y)) {
    griddy_abort(where, " should hold a numeric runs x outputs matrix; it holds ",
                 class(y)[1], if (is.matrix(y)) paste0(" of type ", typeof(y)), ".",
                 class = "library")
  }
  if (nrow(y) != n_rows || ncol(y) != n_out) {
    griddy_abort(where, " holds ", nrow(y), " x ", ncol(y), " (runs x outputs) where the ",
                 "library expects ", n_rows, " x ", n_out, ": the library is damaged or was ",
                 "changed after it was written.", class = "library")
  }
  if (!is.double(y)) storage.mode(y) <- "double"
  if (!all(is.finite(y))) {
    bad <- which(!is.finite(y), arr.ind = TRUE)
    griddy_abort(where, " holds non-finite outputs (", show_some(y[bad]), ") at run(s) ",
                 show_some(unique(bad[, 1] + first - 1L)), ".", class = "library")
  }
  y
}

# Integrity of the in-memory part every backend shares: `theta` a data.frame
# of finite doubles with `n_runs` rows, and `n_out` outputs per run as x and t
# give. Errors of class "shape" name what was edited.
check_library_parts <- function(library, n_runs, n_out, what,
                                fix = "Open the library again.") {
  theta <- library$theta
  if (!is.data.frame(theta) || ncol(theta) < 1L ||
      !all(vapply(theta, is.double, logical(1)))) {
    griddy_abort("The ", what, " has been edited: `theta` must be a data.frame of double ",
                 "columns; received ", class(theta)[1], ". ", fix,
                 class = "shape")
  }
  if (nrow(theta) != n_runs) {
    griddy_abort("The ", what, " has been edited: `theta` has ", nrow(theta), " rows but ",
                 "the library holds ", n_runs, " runs. ", fix,
                 class = "shape")
  }
  if (!all(vapply(theta, function(v) is.finite(sum(v)), logical(1)))) {
    tryCatch(assert_finite(as.matrix(theta), "library$theta"), griddy_error = function(e) {
      griddy_abort("The ", what, " has been edited: ", conditionMessage(e),
                   " ", fix, class = "shape")
    })
  }
  if (!is.null(library$x) && !is.data.frame(library$x) || !is.numeric(library$t)) {
    griddy_abort("The ", what, " has been edited: `x` must be a data.frame or NULL and `t` ",
                 "a numeric vector. ", fix, class = "shape")
  }
  if (lib_n_out(library) != n_out) {
    griddy_abort("The ", what, " has been edited: x and t give ", lib_n_x(library), " x ",
                 lib_n_t(library), " = ", lib_n_out(library), " outputs per run but the ",
                 "library holds ", n_out, ". ", fix, class = "shape")
  }
  invisible(library)
}
