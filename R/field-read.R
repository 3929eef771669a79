#' Read the thesis's three calibration inputs
#'
#' Reads `design`, `simobs` and `expobs` in the layout of the Los Alamos
#' `simobs` code that the thesis's R code takes (Appendix A.1), and does its
#' "rearrange truth & simobs" step: runs that share \eqn{\theta} become one
#' library row, with their outputs in blocks ordered as `expobs`'s x settings.
#'
#' * `design`: one row per simulation run, the `n_x` x columns first and the
#'   \eqn{\theta} columns after. Each x setting is a separate run.
#' * `simobs`: one row per `design` row holding that run's `n_t` outputs, or
#'   the transposed layout, one column per `design` row (as the Los Alamos
#'   `simobs` code writes it); see `simobs_layout`.
#' * `expobs`: one row per experiment, the `n_x` x columns first, then the
#'   `n_t` measurements (`NA` or an empty cell where not measured). Rows at
#'   the same x setting (all rows, when `n_x` is 0) are replicated
#'   experiments (see [field_data()]).
#'
#' Files are read with [data.table::fread()] (csv or whitespace-separated).
#' Comment lines, starting with `#`, are skipped wherever they are. A header
#' line is optional: a file whose first line is all numbers has
#' none, and its columns are named `V1`, `V2`, ... (so a header line must
#' hold at least one name that is not a number). Whole numbers too large for
#' an integer are read as doubles.
#'
#' **Any design.** When every \eqn{\theta} of `design` was run at every x
#' setting of `expobs`, the runs are the library, a [sim_library()] (runs at
#' settings that `expobs` lacks are dropped, with a message). Otherwise (a
#' Latin hypercube over \eqn{(x, \theta)} jointly, an incomplete design,
#' field settings no run has) a library of `n_runs` runs at `expobs`'s
#' settings is emulated from all the runs, an [emulated_library()], and a
#' message (class `griddy_message_emulated`) says so and gives the
#' emulator's leave-one-out error; the emulator's error enters the
#' likelihood. Missing values (NA) in `expobs`'s measurements are passed on
#' to [field_data()].
#'
#' @param design,simobs,expobs File paths, data.frames or matrices, as above.
#'   All their columns must be numeric (integer, double or `bit64`'s
#'   integer64); `design`'s columns need distinct names (the x columns' names
#'   name the settings of the library and the field data).
#' @param n_x The number of x columns (control variables) in `design` and
#'   `expobs`; 0 when there are none.
#' @param t Optional output coordinates of `simobs`'s outputs (see
#'   [sim_library()]); `NULL` gives `1:n_t`.
#' @param t_field `NULL` (the default: `expobs`'s measurements are at `t`), or
#'   the output coordinates of `expobs`'s measurements when the field was
#'   measured elsewhere than the simulator wrote its outputs (e.g. heights
#'   between the simulator's). `expobs` then holds `length(t_field)`
#'   measurements per row, and each run's outputs are first interpolated
#'   along `t` to `t_field` by a cubic spline ([stats::splinefun()],
#'   `"fmm"`), so the library, simulated or emulated, is at `t_field`. A
#'   message (class `griddy_message_interpolated`) gives the interpolation
#'   error, estimated by leaving each interior coordinate of `t` out; it is
#'   not in the likelihood, so the runs' outputs should be dense enough along
#'   `t` for it to be small against the noise. `t_field` must lie within
#'   `t`'s range (a spline does not extrapolate well).
#' @param simobs_layout How `simobs` holds the runs: `"runs_in_rows"` (one
#'   row per `design` row), `"runs_in_columns"` (one column per `design`
#'   row) or `"auto"` (the default: the one that fits `design`). When
#'   `simobs` is square, with as many outputs per run as `design` has rows,
#'   both fit and `"auto"` is refused: say which it is.
#' @param n_runs,seed For an emulated library: its number of runs, and
#'   `NULL` or a seed for this call only (see [emulated_library()]).
#' @return A list with elements `library` (a [sim_library()], or an
#'   [emulated_library()] when the runs do not form one) and `field` (a
#'   [field_data()] object).
#' @examples
#' dir <- system.file("extdata", package = "griddy")
#' inputs <- read_calibration_inputs(
#'   design = file.path(dir, "oscillator_design.csv"),
#'   simobs = file.path(dir, "oscillator_simobs.csv"),
#'   expobs = file.path(dir, "oscillator_expobs.csv"),
#'   n_x = 1
#' )
#' inputs$library
#'
#' # field heights between the simulator's: its runs are interpolated to them
#' heights <- c(2, 4, 6)
#' design <- data.frame(r = rep(c(1, 2), each = 3), k = rep(1:3, 2))
#' simobs <- t(sapply(seq_len(nrow(design)), function(i) {
#'   design$k[i] * sqrt(heights) / design$r[i]
#' }))
#' expobs <- data.frame(r = c(1, 2), h3 = c(3.5, 1.7), h5 = c(4.4, 2.3))
#' inputs <- read_calibration_inputs(design, simobs, expobs, n_x = 1,
#'                                   t = heights, t_field = c(3, 5))
#' inputs$library$t
#' @export
read_calibration_inputs <- function(design, simobs, expobs, n_x, t = NULL, t_field = NULL,
                                    simobs_layout = c("auto", "runs_in_rows",
                                                      "runs_in_columns"),
                                    n_runs = 10000, seed = NULL) {
  n_x <- assert_count(n_x, "n_x", min = 0L)
  n_runs <- assert_count(n_runs, "n_runs", min = 2L)
  seed <- assert_seed(seed)
  simobs_layout <- assert_choice(simobs_layout, "simobs_layout",
                                 c("auto", "runs_in_rows", "runs_in_columns"),
                                 vector_default = TRUE)
  design <- read_table_input(design, "design")
  simobs <- read_table_input(simobs, "simobs")
  expobs <- read_table_input(expobs, "expobs", na_ok = TRUE)
  assert_column_names(design, "design")
  if (ncol(design) <= n_x) {
    griddy_abort("`design` must have the ", n_x, " x column(s) and at least one theta ",
                 "column; it has ", ncol(design), " column(s).")
  }
  sim <- orient_simobs(simobs, nrow(design), simobs_layout)
  n_t <- ncol(sim)
  t_field <- assert_output_coordinates(t_field, "t_field")
  if (!is.null(t_field)) {
    t_sim <- as_coordinates(t, n_t, "t", "outputs per run in `simobs`")
    sim <- interpolate_outputs(sim, t_sim, t_field, "t_field")
    inform_interpolated(n_t, t_field, attr(sim, "loo_rms"))
    t <- t_field
    n_t <- length(t_field)
  }
  if (ncol(expobs) != n_x + n_t) {
    griddy_abort("`expobs` must have the ", n_x, " x column(s) then the ", n_t,
                 if (is.null(t_field)) " measurements that `simobs` has per run" else
                   " measurements at `t_field`", "; it has ", ncol(expobs), " column(s).")
  }
  x_cols <- seq_len(n_x)
  if (n_x > 0L) assert_finite(as.matrix(expobs[, x_cols, drop = FALSE]), "expobs's x columns")
  x_names <- names(design)[x_cols]
  exp_x <- stats::setNames(as.data.frame(expobs[, x_cols, drop = FALSE]), x_names)
  # rows of expobs at one x setting are replicated experiments (see ?field_data)
  settings <- if (n_x > 0L) unique(exp_x) else exp_x[1L, , drop = FALSE]
  rownames(settings) <- NULL
  setting <- design_settings(design[, x_cols, drop = FALSE], settings)
  used <- !is.na(setting)
  theta <- as.data.frame(design[used, setdiff(seq_len(ncol(design)), x_cols), drop = FALSE])
  run <- row_groups(theta)
  assert_distinct_pairs(run, setting[used], which(used))
  lib_x <- if (n_x > 0L) settings else NULL
  field <- expobs_field(expobs, exp_x, n_x, n_t, t)
  if (!forms_library(run, setting[used], nrow(settings))) {
    library <- emulate_design(design, sim, n_x, lib_x, t, n_runs, seed)
    return(list(library = library, field = field))
  }
  if (any(!used)) {
    message(sum(!used), " `design` run(s) at x settings that `expobs` lacks ",
            "were dropped (row(s) ", show_some(which(!used)), ").")
  }
  y <- matrix(NA_real_, max(run), nrow(settings) * n_t)
  cols <- outer((setting[used] - 1L) * n_t, seq_len(n_t), "+")
  y[cbind(rep(run, n_t), as.vector(cols))] <- as.vector(sim[used, , drop = FALSE])
  library <- sim_library(theta[!duplicated(run), , drop = FALSE], y, x = lib_x, t = t)
  list(library = library, field = field)
}

# The field data of expobs, its replicates kept as they are. Without x
# columns every row is an experiment at the one setting: a long-format
# field without x (see ?field_data).
expobs_field <- function(expobs, exp_x, n_x, n_t, t) {
  y <- as.matrix(expobs[, n_x + seq_len(n_t), drop = FALSE])
  dimnames(y) <- NULL
  if (n_x > 0L || nrow(y) == 1L) return(field_data(y, x = if (n_x > 0L) exp_x, t = t))
  coords <- if (is.null(t)) seq_len(n_t) else t
  long <- data.frame(t = rep(coords, times = nrow(y)), y = as.vector(t(y)))
  field_data(long[!is.na(long$y), , drop = FALSE])
}

# The emulated library of a design that does not form one at the field's
# settings, said in a message with its leave-one-out error.
emulate_design <- function(design, sim, n_x, settings, t, n_runs, seed) {
  x_cols <- seq_len(n_x)
  theta <- as.matrix(design[, setdiff(seq_len(ncol(design)), x_cols), drop = FALSE])
  x <- if (n_x > 0L) design[, x_cols, drop = FALSE]
  library <- emulated_library(theta, sim, x = x, t = t, settings = settings,
                              n_runs = n_runs, seed = seed)
  form <- if (lib_design_emulator(library)$mode == "joint") "(x, theta) -> outputs" else "theta -> outputs"
  loo <- format(emulated_loo_rms(library), digits = 3)
  n_design <- nrow(design)
  cli::cli_inform(c(
    i = paste0("The {n_design} design runs do not form a library at the x settings of ",
               "`expobs` (every theta at every setting), so a library of {n_runs} runs was ",
               "emulated from them (RobustGaSP ppgasp, {form})."),
    i = paste0("Its leave-one-out error (RMS) is {loo}; it enters the likelihood, and ",
               "calibrate() warns when it exceeds the noise (see ?emulated_library).")),
    class = "griddy_message_emulated")
  library
}

# A file path, data.frame or matrix as a data.frame of doubles; with
# `na_ok`, missing cells stay NA (the field's missing measurements).
read_table_input <- function(v, arg, na_ok = FALSE) {
  headerless <- FALSE
  if (is.character(v) && length(v) == 1L && !is.na(v)) {
    v <- read_input_file(v, arg)
    headerless <- attr(v, "headerless")
  }
  if (!is.data.frame(v) && !is.matrix(v)) {
    griddy_abort("`", arg, "` must be a file path, a data.frame or a matrix; received ",
                 class(v)[1], if (is.character(v)) paste0(" of length ", length(v)), ".")
  }
  v <- as.data.frame(v)
  if (nrow(v) < 1L || ncol(v) < 1L) {
    griddy_abort("`", arg, "` is empty.")
  }
  na <- if (na_ok) is.na(v) else FALSE
  if (any(na)) v[na] <- 0
  m <- as_numeric_matrix(v, arg)
  m[na] <- NA_real_
  v[] <- lapply(seq_len(ncol(m)), function(j) m[, j])
  attr(v, "headerless") <- headerless
  v
}

# Read one input file. A first line of numbers only is data, not a header
# (fread(header = TRUE) would take the first run for column names). Comment
# lines (starting with `#`, after optional blanks) are dropped first:
# fread() would take a leading one for the header, and the header then for
# a row of data (this data.table has no comment character).
read_input_file <- function(path, arg) {
  if (!file.exists(path) || dir.exists(path)) {
    griddy_abort("`", arg, "` file not found: ", path)
  }
  source <- list(file = path)
  if (file_has_byte(path, "#")) {
    lines <- readLines(path, warn = FALSE)
    comment <- grepl("^[[:blank:]]*#", lines)
    if (any(comment)) source <- list(text = lines[!comment])
  }
  read <- function(...) {
    tryCatch(do.call(data.table::fread,
                     c(source, list(data.table = FALSE, integer64 = "double", ...))),
             error = function(e) griddy_abort("`", arg, "` could not be read from ", path,
                                              ": ", conditionMessage(e)))
  }
  first <- read(header = FALSE, nrows = 1L, colClasses = "character")
  fields <- trimws(unlist(first, use.names = FALSE))
  numbers <- suppressWarnings(as.numeric(fields))
  headerless <- length(fields) > 0L && all(!is.na(numbers))
  structure(read(header = !headerless), headerless = headerless)
}

# Whether a file holds the character `char` anywhere: a scan of its raw
# bytes, 16 MB at a time, several times faster than reading its lines (so a
# file without comments is read by fread() alone).
file_has_byte <- function(path, char) {
  byte <- charToRaw(char)
  con <- file(path, "rb")
  on.exit(close(con))
  repeat {
    chunk <- readBin(con, "raw", 2^24)
    if (length(chunk) == 0L) return(FALSE)
    if (length(grepRaw(byte, chunk, fixed = TRUE)) > 0L) return(TRUE)
  }
}

# simobs as a runs x outputs matrix: one row per design row, or one column
# per design row, as `layout` says ("auto": the one that fits, refusing a
# square simobs, which both fit).
orient_simobs <- function(simobs, n_design, layout = "auto") {
  hint <- if (isTRUE(attr(simobs, "headerless"))) {
    paste0(" (The first line of the file holds numbers only, so it was read as data; ",
           "if it is a header, e.g. of output times, give it a non-numeric name or drop it.)")
  }
  sim <- as.matrix(simobs)
  dimnames(sim) <- NULL
  fits_rows <- nrow(sim) == n_design
  fits_cols <- ncol(sim) == n_design
  if (layout == "auto") {
    if (fits_rows && fits_cols) {
      griddy_abort("`simobs` is ", nrow(sim), " x ", ncol(sim), ", as many outputs per run ",
                   "as `design` has rows (", n_design, "), so whether its runs are its rows ",
                   "or its columns is ambiguous; say which with simobs_layout = ",
                   "\"runs_in_rows\" (one row per `design` row) or \"runs_in_columns\" ",
                   "(one column per `design` row, the Los Alamos simobs layout).")
    }
    if (!fits_rows && !fits_cols) {
      griddy_abort("`simobs` must have one row (or one column) per `design` row (",
                   n_design, "); it is ", nrow(sim), " x ", ncol(sim), ".", hint)
    }
    layout <- if (fits_rows) "runs_in_rows" else "runs_in_columns"
  }
  if (layout == "runs_in_rows") {
    if (!fits_rows) {
      griddy_abort("`simobs` must have one row per `design` row (", n_design, ") with ",
                   "simobs_layout = \"runs_in_rows\"; it is ", nrow(sim), " x ", ncol(sim), ".",
                   hint)
    }
    return(sim)
  }
  if (!fits_cols) {
    griddy_abort("`simobs` must have one column per `design` row (", n_design, ") with ",
                 "simobs_layout = \"runs_in_columns\"; it is ", nrow(sim), " x ", ncol(sim), ".",
                 hint)
  }
  t(sim)
}

# For each design row, the expobs row holding its x setting (NA: none).
design_settings <- function(design_x, exp_x) {
  if (ncol(design_x) == 0L) {
    return(rep(1L, nrow(design_x)))
  }
  match_rows(design_x, exp_x)
}

assert_distinct_pairs <- function(run, setting, rows) {
  pair <- paste(run, setting)
  dup <- which(duplicated(pair))
  if (length(dup) > 0L) {
    griddy_abort("`design` has duplicated (x, theta) rows: row(s) ", show_some(rows[dup]),
                 " repeat row(s) ", show_some(rows[match(pair[dup], pair)]), ".")
  }
}

# The runs at the field's settings form a library: each theta run once at
# every setting.
forms_library <- function(run, setting, n_settings) {
  if (length(run) == 0L) return(FALSE)
  all(tabulate(run, nbins = max(run)) == n_settings)
}
