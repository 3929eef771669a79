# A library as base R objects: its parameter values as a data.frame and its
# outputs as a matrix, for every backend, read through the library
# interface (lib_theta(), lib_outputs()).

#' A library's runs as a data.frame or a matrix
#'
#' `as.data.frame()` gives a library's parameter values \eqn{\theta}, one row
#' per run (in the library's run order); `as.matrix()` gives its outputs in
#' the library layout: one row per run, and the `n_x * n_t` outputs of a run
#' in blocks of `n_t` by x setting (as in [sim_library()]). Both work for
#' every library: [sim_library()], [hdf5_library()], [disk_library()],
#' [emulated_library()] (its predicted runs) and the refined libraries of
#' [refine()].
#'
#' The outputs of a library on disk can be larger than memory, so
#' `as.matrix()` first compares their size, `8 * N * n_x * n_t` bytes, with
#' `max_bytes` and stops with an error of class `griddy_error_memory` naming
#' the size when it is larger. Raise `max_bytes` to read them anyway, or read
#' what you need in pieces (for example from a smaller library written with
#' [write_library()]).
#'
#' @param x A library.
#' @param row.names,optional Unused (the rows are the runs, unnamed).
#' @param max_bytes The largest output matrix, in bytes, that `as.matrix()`
#'   builds: by default the option `griddy.max_bytes`, or 2 GB.
#' @param ... Unused.
#' @return `as.data.frame()`: a data.frame with one column per parameter and
#'   one row per run. `as.matrix()`: a numeric matrix of `N` rows (runs) and
#'   `n_x * n_t` columns (outputs, blocks by x setting).
#' @seealso [sim_library()], [hdf5_library()]
#' @examples
#' ex <- griddy_example()
#' head(as.data.frame(ex$library))
#' dim(as.matrix(ex$library))
#' try(as.matrix(ex$library, max_bytes = 1e4))
#' @name library_coerce
NULL

library_as_data_frame <- function(x, row.names = NULL, optional = FALSE, ...) {
  check_library(x)
  theta <- as.data.frame(lib_theta(x))
  rownames(theta) <- NULL
  theta
}

library_as_matrix <- function(x, ..., max_bytes = getOption("griddy.max_bytes", 2e9)) {
  check_library(x)
  if (!is.numeric(max_bytes) || length(max_bytes) != 1L || is.na(max_bytes) ||
      max_bytes <= 0) {
    griddy_abort("`max_bytes` must be a positive number of bytes; received ",
                 paste(format(max_bytes), collapse = ", "), ".")
  }
  n_runs <- lib_n_runs(x)
  n_out <- lib_n_out(x)
  bytes <- 8 * as.double(n_runs) * n_out
  if (bytes > max_bytes) {
    size <- function(b) format(structure(b, class = "object_size"), units = "auto",
                               standard = "SI")
    griddy_abort("The outputs of this ", class(x)[1], " are ", format(n_runs, big.mark = ","),
                 " runs x ", format(n_out, big.mark = ","), " outputs = ", size(bytes),
                 ", more than `max_bytes` (", size(max_bytes), "): nothing was read. Raise ",
                 "`max_bytes` (or options(griddy.max_bytes = )) if memory holds them.",
                 class = "memory")
  }
  out <- lib_outputs(x)
  dimnames(out) <- NULL
  out
}

#' @rdname library_coerce
#' @export
as.data.frame.sim_library <- library_as_data_frame
#' @rdname library_coerce
#' @export
as.data.frame.hdf5_library <- library_as_data_frame
#' @rdname library_coerce
#' @export
as.data.frame.disk_library <- library_as_data_frame
#' @rdname library_coerce
#' @export
as.data.frame.emulated_library <- library_as_data_frame
#' @rdname library_coerce
#' @export
as.data.frame.refined_library <- library_as_data_frame

#' @rdname library_coerce
#' @export
as.matrix.sim_library <- library_as_matrix
#' @rdname library_coerce
#' @export
as.matrix.hdf5_library <- library_as_matrix
#' @rdname library_coerce
#' @export
as.matrix.disk_library <- library_as_matrix
#' @rdname library_coerce
#' @export
as.matrix.emulated_library <- library_as_matrix
#' @rdname library_coerce
#' @export
as.matrix.refined_library <- library_as_matrix
