#' Run a simulation campaign into an HDF5 library
#'
#' Runs `simulator` over the rows of `design` through the user's
#' [future][future::plan] plan and commits the finished runs, chunk by
#' chunk, to the HDF5 library `file` (the format of [write_library()], with
#' its safe appends and lock), with a progress bar. Run again on the same
#' file, it resumes: the design rows already in the file (matched by their
#' \eqn{\theta} values, to within \eqn{10^{-8}} of each parameter's largest
#' absolute value, so that a design saved with `write.csv()` or
#' `data.table::fwrite()` and read back is the same design) are skipped, so
#' a killed R session, a lost node or a cancelled job costs at most the runs
#' that were in flight.
#'
#' **The simulator.** `simulator(theta, ...)` receives a data.frame of
#' \eqn{\theta} rows (the design's columns, several rows per call) and
#' returns a numeric matrix of their outputs: one row per \eqn{\theta} row,
#' in order, and one column per output, in blocks by x setting (the layout of
#' [sim_library()]: `n_x * n_t` columns). The same function serves
#' [refine()]. A call that stops with an error fails all its rows; a row
#' with a non-finite output fails alone.
#'
#' **Where it runs.** The design is cut into chunks, about four per worker
#' (at least ten). Under the default sequential plan they run in this
#' process, one after the other; under a plan with more workers (a
#' `multisession` plan, or cluster jobs through future.batchtools, see
#' `vignette("simulate-library")`) each chunk is a future, one per worker
#' at a time, and each is committed as soon as it finishes. The simulator's
#' globals (the variables and functions it uses) and packages reach the
#' workers as [future][future::future] finds them for any future; workers
#' need those packages installed, not griddy. For Slurm, griddy
#' ships a batchtools template, `system.file("templates",
#' "batchtools.slurm.tmpl", package = "griddy")`; its jobs are named
#' `griddy-simulator`. The library can be opened (with [hdf5_library()])
#' from another session while the campaign runs: a commit waits for such
#' readers (up to a minute). Each chunk has its
#' own seed drawn from R's stream, so `set.seed()` (or `seed`) makes a
#' stochastic simulator reproducible.
#'
#' **Failures.** A chunk whose call fails (an error, or a future that cannot
#' deliver its value: a worker that died, a cancelled job) is run again row
#' by row, so only the rows that fail on their own are left out. A run whose
#' worker is lost is run again, alone; one lost again (it kills its worker)
#' fails. After a lost worker the plan's workers are
#' restarted, once the runs still in flight are in, so the plan is whole when
#' `simulate_library()` returns. A condition without a message is reported by
#' its classes. The failed rows are
#' named, with the simulator's messages, in one warning of class
#' `griddy_warning_simulation_failed`; recorded in the file (dataset
#' `failed`: the design row, \eqn{\theta} and the message, replaced by every
#' call) and in the attribute `"failed"` of the result; and, since they are
#' not in the library, run again by the next call on the same file (after
#' the simulator is fixed, say). An interrupt stops the campaign at once;
#' the chunks committed stay.
#'
#' @param simulator A function of a data.frame of \eqn{\theta} rows (and
#'   `...`) returning their outputs: see Details.
#' @param design The runs to simulate: a data.frame (or a matrix with column
#'   names) of distinct \eqn{\theta} rows, one column per parameter, such as
#'   [design_lhs()] or [design_grid()] draw.
#' @param file Path of the HDF5 file of the library: created by the first
#'   call, added to by the next ones (which must use the same parameters,
#'   `x` and `t`).
#' @param x The control settings of the outputs, as in [sim_library()].
#' @param t The output coordinates, as in [sim_library()]; `NULL` numbers
#'   the outputs per x setting (their count is then set by the simulator's
#'   first result).
#' @param ... Further arguments to `simulator`.
#' @param seed `NULL`, or a seed for this call only.
#' @param progress Show a progress bar.
#' @param control Settings from [griddy_control()]; `progress` overrides its
#'   field.
#' @return The [hdf5_library()] in `file` (every committed run, of this call
#'   and earlier ones), with an attribute `"failed"`: a data.frame of the
#'   design rows that failed in this call (`row`, their \eqn{\theta} and the
#'   simulator's `message`; no rows when none failed).
#' @seealso [design_lhs()], [design_grid()], [hdf5_library()],
#'   [write_library()], [refine()]
#' @examples
#' if (requireNamespace("hdf5r", quietly = TRUE)) {
#'   sim <- function(theta) {
#'     t <- seq(0, 1, length.out = 20)
#'     t(vapply(theta$k, function(k) sin(k * t), numeric(20)))
#'   }
#'   design <- design_lhs(30, k = c(1, 4), seed = 1)
#'   file <- tempfile(fileext = ".h5")
#'   lib <- simulate_library(sim, design, file, t = seq(0, 1, length.out = 20))
#'   lib
#'   # run again with a larger design on the same file, and only the new rows
#'   # are simulated: see vignette("simulate-library")
#'   unlink(file)
#' }
#' @export
simulate_library <- function(simulator, design, file, x = NULL, t = NULL, ..., seed = NULL,
                             progress = control$progress, control = griddy_control()) {
  require_package("hdf5r", "to write the library to an HDF5 file")
  control <- assert_control(control)
  if (!is.function(simulator)) {
    griddy_abort("`simulator` must be a function of a data.frame of theta rows; received ",
                 class(simulator)[1], ".")
  }
  design <- as.data.frame(as_theta_matrix(design))
  if (nrow(design) < 1L) griddy_abort("`design` has no rows.")
  assert_distinct_runs(as.matrix(design))
  file <- assert_string(file, "file")
  if (dir.exists(file)) {
    griddy_abort("`file` (", file, ") is a directory; give the path of an HDF5 file.")
  }
  x <- as_settings(x, "x")
  if (!is.null(t)) t <- as_coordinates(t, length(t), "t", "coordinates")
  seed <- assert_seed(seed)
  progress <- assert_flag(progress, "progress")

  campaign <- campaign_todo(design, file)
  n_out <- campaign$n_out
  if (is.null(n_out) && !is.null(t)) n_out <- length(t) * n_settings(x)
  todo <- campaign$todo
  theta <- campaign$design[todo, , drop = FALSE]
  commit <- function(rows, y) {
    if (is.null(t) && ncol(y) %% n_settings(x) != 0L) {
      griddy_abort("`simulator` returned ", ncol(y), " outputs per run, which is not a ",
                   "multiple of the ", n_settings(x), " x settings (rows of `x`).",
                   class = "shape")
    }
    run_t <- if (is.null(t)) as.double(seq_len(ncol(y) %/% n_settings(x))) else t
    commit_runs(runs_piece(theta[rows, , drop = FALSE], y, x, run_t), file,
                append = file.exists(file))
  }
  failed <- if (length(todo) > 0L) {
    run <- simulator_caller(simulator, list(...))
    with_seed(seed, run(theta, n_out, progress, commit))
  } else {
    list()
  }
  report <- failed_table(failed, theta, todo)
  if (!file.exists(file)) {
    griddy_abort("The simulator failed on every run of the design, so `file` (", file,
                 ") was not created: ", paste(utils::head(report$message, 3L),
                                              collapse = "; "), class = "simulator")
  }
  record_failed(file, report)
  if (nrow(report) > 0L) warn_failed(report, length(todo), file)
  out <- hdf5_library(file)
  attr(out, "failed") <- report
  out
}

# The design rows not yet in `file` (by their theta values, to
# match_rows()'s tolerance: a design written to CSV and read back is the same
# design), the
# design with its columns in the file's order, and the file's outputs per
# run (NULL for a new file).
campaign_todo <- function(design, file) {
  held <- h5_committed_theta(file)
  if (is.null(held)) return(list(design = design, todo = seq_len(nrow(design)), n_out = NULL))
  if (!setequal(names(held$theta), names(design)) ||
      length(names(held$theta)) != length(names(design))) {
    griddy_abort("`design` must have the parameters of the library in `file` (", file,
                 "): it has ", show_some(names(design)), ", the file ",
                 show_some(names(held$theta)), ". Give another `file`.", class = "library")
  }
  design <- design[names(held$theta)]
  list(design = design, todo = which(is.na(match_rows(design, held$theta))),
       n_out = held$n_out)
}

# The failed rows as a data.frame: the design row, theta and the message.
failed_table <- function(failed, theta, todo) {
  rows <- vapply(failed, `[[`, 1L, "row")
  data.frame(row = todo[rows], theta[rows, , drop = FALSE],
             message = vapply(failed, function(f) condition_text(f$condition), ""),
             row.names = NULL, check.names = FALSE, stringsAsFactors = FALSE)
}

# The failed rows in the file, dataset `failed` (replaced; removed when
# none failed), written under the library's lock.
record_failed <- function(file, report) {
  token <- library_lock(file, "library file")
  on.exit(library_unlock(token), add = TRUE)
  h5 <- h5_open(file, "r+")
  on.exit(h5_close(h5), add = TRUE, after = FALSE)
  if (h5$exists("failed")) h5$link_delete("failed")
  if (nrow(report) > 0L) h5[["failed"]] <- report
  invisible()
}

warn_failed <- function(report, n_todo, file) {
  theta <- report[setdiff(names(report), c("row", "message"))]
  # the first line of each message (a scheduler's may run on for pages)
  first_line <- substr(sub("(?s)\n.*", "", report$message, perl = TRUE), 1L, 200L)
  lines <- paste0("design row ", report$row, " (",
                  vapply(seq_len(nrow(report)), function(i) show_theta(theta, i), ""), "): ",
                  first_line)
  griddy_warn("The simulator failed on ", nrow(report), " of ", n_todo, " run(s); ",
              "they are left out of ", file, " (listed in its dataset `failed` and in ",
              "attr(, \"failed\") of the result) and run again by the next ",
              "simulate_library() on it: ", paste(utils::head(lines, 10L), collapse = "; "),
              if (length(lines) > 10L) paste0("; and ", length(lines) - 10L, " more"), ".",
              class = "simulation_failed")
}
