# The library interface. Code outside the library files (library_*.R,
# library-sim.R) reads a library only through these functions, never through
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
# engine.R. A matrix, or, for a backend that finds more beside it
# (extra log-determinants, an emulated library's error and plug-in), a list
# with C and those (misfit_parts()): never attributes on C.
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
# over the future plan's workers (griddy_map()) in waves of one piece per
# worker, each wave's results copied into C at once, so memory holds C and one
# wave of pieces. `pieces` is a list of read specifications (see
# read_piece()), `rows` the number of runs in each, in library order. Workers
# need griddy installed, and share griddy_threads() between them.
chunked_quad_forms <- function(pieces, rows, y_field, setup) {
  piece_C <- function(piece, y_field, setup, threads) {
    plain_quad_forms(read_piece(piece), y_field, setup, threads)
  }
  environment(piece_C) <- asNamespace("griddy")
  per_wave <- griddy_workers()
  ends <- cumsum(rows)
  C <- matrix(0, sum(rows), n_grid_points(setup))
  for (wave in split(seq_along(pieces), (seq_along(pieces) - 1L) %/% per_wave)) {
    out <- griddy_map(pieces[wave], piece_C, y_field = y_field, setup = setup,
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

# ---- what refine() reads of a library ---------------------------------------
#
# refine() adds runs round by round (a refined library, library-refined.R),
# predicts them from the library when it has no simulator, and replaces
# predicted runs with simulated ones when it has. It reads a library only
# through these functions.

# The library refine() started from: the base of a refined library, else the
# library itself. Its range is the prior's.
lib_base <- function(library) UseMethod("lib_base")

#' @exportS3Method
lib_base.default <- function(library) library

# refine()'s rounds: a list of list(box, n, source, error), one per round (box
# a 2 x p matrix of lower and upper bounds, n its runs, source "simulator" or
# "emulator", error its emulation-error model or NULL); none for a library
# refine() has not touched.
lib_rounds <- function(library) UseMethod("lib_rounds")

#' @exportS3Method
lib_rounds.default <- function(library) list()

# Which runs were predicted by an emulator (logical, one per run) rather than
# simulated.
lib_predicted <- function(library) UseMethod("lib_predicted")

#' @exportS3Method
lib_predicted.default <- function(library) logical(lib_n_runs(library))

# The simulated runs as a plain library (for an emulator to learn from), or
# NULL when there are none.
lib_simulated <- function(library) UseMethod("lib_simulated")

#' @exportS3Method
lib_simulated.default <- function(library) library

# The quadratic forms C of library rows `rows` (runs x grid points), with the
# emulation error of predicted runs: a matrix, or list(C, extra_logdet) (see
# lib_quad_forms(), fold_extra_logdet()); the rows a refinement adds are
# computed without the rest.
lib_run_quad_forms <- function(library, rows, y_field, setup) {
  UseMethod("lib_run_quad_forms")
}

#' @exportS3Method
lib_run_quad_forms.default <- function(library, rows, y_field, setup) {
  plain_quad_forms(lib_outputs(library, rows), y_field, setup)
}

# The library with its predicted runs' error put on the scale of plug-in
# noise variance `noise_var` (one per noise group) for field data `y_field`.
# A library without predicted runs is returned as it is.
lib_with_noise_var <- function(library, noise_var, y_field) UseMethod("lib_with_noise_var")

#' @exportS3Method
lib_with_noise_var.default <- function(library, noise_var, y_field) library

# The plug-in noise variances the predicted runs' error is on now: one value
# per noise group for each part with predicted runs (an emulated base, each
# round of predicted runs), NA for a part that holds none yet; numeric(0)
# when no run is predicted. With lib_with_noise_var() and
# lib_run_quad_forms() of the predicted runs, what restating the noise
# variance needs.
lib_noise_var <- function(library) UseMethod("lib_noise_var")

#' @exportS3Method
lib_noise_var.default <- function(library) numeric()

# Which runs were predicted and the error model of each: list(n_base = the
# base library's runs, base = list(error, kappa) for a predicted base (an
# emulated library: its error model at its plug-in noise variance, its
# shared kappa) or NULL, round = each added run's round, kappa = each added
# run's relative variance, errors = each round's error model or NULL,
# replaced = runs a simulator replaced, now plain), or NULL when no run was
# predicted. What the noise groups' forms (run_group_forms()) and the gap
# diagnosis's leave-block pieces need.
lib_prediction_errors <- function(library) UseMethod("lib_prediction_errors")

#' @exportS3Method
lib_prediction_errors.default <- function(library) NULL

# A sim_library of any number of runs (one is enough), unchecked: a piece of
# runs to write to a file (write_library(append = TRUE)), or a part of a
# library, whose runs were checked where they came from.
runs_piece <- function(theta, y, x, t) {
  structure(list(theta = as.data.frame(theta), y = y, x = x, t = t), class = "sim_library")
}

# ---- the emulation-error contract --------------------------------------------
#
# refine() without a simulator predicts its runs; the emulators and their
# error model live in library_emulator*.R, library-emulated.R and (the
# error model) emulation.R. refine() reaches them only through these
# two functions:
#
# * lib_emulator(library, region): an emulator of the library's runs over
#   `region` (a 2 x p data.frame of bounds inside the library's range),
#   list(refine_region = the region it answers in (2 x p matrix), loo = its
#   leave-one-out residuals (runs x outputs), loo_theta = their runs (runs x
#   p matrix), method, ...).
# * lib_predict(emulator, theta_new, noise_var): the runs at the rows of
#   theta_new, list(y = outputs (rows x outputs, library layout), rel_var =
#   kappa of each, the prediction's relative variance (0 at a simulated run),
#   error = the error model at plug-in noise variance `noise_var` (NULL for
#   none), which lib_run_quad_forms() of a refined library applies).
lib_emulator <- function(library, region, ...) UseMethod("lib_emulator")

# `max_runs`: the most runs a Gaussian process is fitted on (see
# library_emulator()).
#' @exportS3Method
lib_emulator.default <- function(library, region, max_runs = 400, ...) {
  emulator <- library_emulator(library, region = region, max_runs = max_runs)
  loo <- emulator_loo(emulator)
  if (!all(is.finite(loo$residuals))) {
    # a Gaussian process too near singular to predict its own runs: the
    # local fit does
    emulator <- library_emulator(library, region = region, method = "local")
    loo <- emulator_loo(emulator)
  }
  emulator$refine_region <- as.matrix(region)
  emulator$loo <- loo$residuals
  emulator$loo_theta <- as.matrix(lib_theta(library)[loo$rows, , drop = FALSE])
  # the error model's directions (an SVD of the residuals, runs x outputs),
  # once per emulator rather than once per round it predicts
  emulator$loo_model <- emulation_error_model(loo$residuals, NA_real_)
  emulator
}

#' @exportS3Method
lib_emulator.emulated_library <- function(library, region, ...) {
  emulated_round_emulator(library)
}

lib_predict <- function(emulator, theta_new, noise_var) {
  if (identical(emulator$method, "emulated_library")) {
    return(emulated_library_batch(emulator$library, theta_new, noise_var))
  }
  pred <- emulator_predict(emulator, theta_new)
  error <- if ("loo_model" %in% names(emulator)) emulator$loo_model else
    emulation_error_model(emulator$loo, noise_var)
  if (!is.null(error)) error$noise_var <- noise_var
  list(y = pred$outputs, rel_var = pred$rel_var, error = error)
}

# The library with what its misfit table (lib_quad_forms()) found for these
# field data kept with it (`plug_in`: an emulated library's noise plug-in
# and shared kappa), so that what reads its error later agrees with C;
# other libraries are returned as they are.
lib_with_plug_in <- function(library, plug_in) UseMethod("lib_with_plug_in")

#' @exportS3Method
lib_with_plug_in.default <- function(library, plug_in) library

# The emulator of the design runs an emulated library was built from (NULL
# for a library of simulated runs): what koh_calibrate() fits instead of its
# own, and what read_calibration_inputs() describes.
lib_design_emulator <- function(library) UseMethod("lib_design_emulator")

#' @exportS3Method
lib_design_emulator.default <- function(library) NULL

