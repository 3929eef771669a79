# The library interface. Code outside the library files (library_*.R,
# sim_library.R) reads a library only through these functions, never through
# its fields, so that a backend -- in memory, an HDF5 file, an old directory
# of .rds chunks -- is a set of methods. Every backend holds theta, x and t in
# memory (N x p, small); the outputs (N x n_x n_t, large) are read on demand.

is_library <- function(library) {
  inherits(library, c("sim_library", "disk_library"))
}

check_library <- function(library, disk = TRUE) {
  if (!inherits(library, "sim_library") && !(disk && is_library(library))) {
    griddy_abort("`library` must be a sim_library (see ?sim_library)",
                 if (disk) " or a disk_library (see ?disk_library)", "; received ",
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
# every grid point of `setup`; see quad_forms() and correlation_setup() in
# correlation.R.
lib_quad_forms <- function(library, y_field, setup) UseMethod("lib_quad_forms")

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
