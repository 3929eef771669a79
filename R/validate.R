# Input checks shared by the constructors and fitters. They run in R before
# any C++ so that the compiled code can trust its inputs.

# Every error griddy raises is a classed condition: `griddy_error_<class>` and
# `griddy_error`, so callers can catch one kind (tryCatch(..., griddy_error_input
# = ...)). The classes:
#   input    an argument of the wrong type, length, range or content;
#   shape    objects whose dimensions do not fit together (library and field,
#            an edited library, a chunk of the wrong size);
#   numeric  a computation that would overflow or is singular;
#   library  a library on disk that is incomplete or corrupt;
#   lock     a library directory held by another writer;
#   package  a suggested package that the call needs is not installed.
# rlang::abort() (what cli::cli_abort() wraps) is called with the message as
# built, so it is never re-wrapped or re-interpolated: a message may hold
# braces and file paths, and reads in full in a log.
griddy_abort <- function(..., class = "input") {
  rlang::abort(paste0(...), class = c(paste0("griddy_error_", class), "griddy_error"),
               call = NULL)
}

griddy_warn <- function(..., class = "general") {
  rlang::warn(paste0(...), class = c(paste0("griddy_warning_", class), "griddy_warning"))
}

# Stop with a clear message when a suggested package is missing.
require_package <- function(pkg, for_what) {
  if (!requireNamespace(pkg, quietly = TRUE)) {
    griddy_abort("Package '", pkg, "' is needed ", for_what, " but is not installed; ",
                 "install it with install.packages(\"", pkg, "\").", class = "package")
  }
}

# Show at most `n` items of a vector in a message, e.g. "3, 7, 9, ... (12 in all)".
show_some <- function(v, n = 5L) {
  v <- as.character(v)
  if (length(v) <= n) {
    return(paste(v, collapse = ", "))
  }
  paste0(paste(v[seq_len(n)], collapse = ", "), ", ... (", length(v), " in all)")
}

# Coerce a data.frame or matrix to a numeric matrix, naming non-numeric
# columns and non-finite cells in the error.
as_numeric_matrix <- function(v, arg) {
  if (is.data.frame(v)) {
    bad <- names(v)[!vapply(v, is.numeric, logical(1))]
    if (length(bad) > 0L) {
      griddy_abort("`", arg, "` must be numeric; column(s) ", show_some(bad),
                   " are ", show_some(unique(vapply(v[bad], function(z) class(z)[1], ""))), ".")
    }
    v <- as.matrix(v)
  } else if (is.numeric(v) && is.null(dim(v))) {
    v <- matrix(v, nrow = 1L)
  }
  if (!is.matrix(v) || !is.numeric(v)) {
    griddy_abort("`", arg, "` must be a numeric matrix or data.frame; received ",
                 class(v)[1], if (is.matrix(v)) paste0(" of type ", typeof(v)), ".")
  }
  storage.mode(v) <- "double"
  assert_finite(v, arg)
  v
}

# Error naming the rows and columns of the first non-finite cells.
assert_finite <- function(v, arg) {
  bad <- which(!is.finite(v), arr.ind = is.matrix(v))
  if (length(bad) == 0L) {
    return(invisible(v))
  }
  if (is.matrix(bad)) {
    cols <- colnames(v)[bad[, 2]]
    if (is.null(cols)) cols <- bad[, 2]
    where <- paste0("[", bad[, 1], ", ", cols, "]")
    what <- v[bad]
  } else {
    where <- paste0("[", bad, "]")
    what <- v[bad]
  }
  griddy_abort("`", arg, "` must hold finite numbers; found ", show_some(what),
               " at ", show_some(where), ".")
}

assert_numeric_vector <- function(v, arg, min_length = 1L) {
  if (!is.numeric(v) || !is.null(dim(v)) && length(dim(v)) > 1L && min(dim(v)) > 1L) {
    griddy_abort("`", arg, "` must be a numeric vector; received ", class(v)[1], ".")
  }
  v <- as.double(v)
  if (length(v) < min_length) {
    griddy_abort("`", arg, "` must have at least ", min_length, " value(s); received ",
                 length(v), ".")
  }
  assert_finite(v, arg)
  v
}

assert_count <- function(v, arg, min = 1L) {
  if (!is.numeric(v) || length(v) != 1L || !is.finite(v) || v != round(v) || v < min) {
    griddy_abort("`", arg, "` must be a single whole number >= ", min, "; received ",
                 paste(format(v), collapse = ", "), ".")
  }
  as.integer(v)
}

assert_string <- function(v, arg) {
  if (!is.character(v) || length(v) != 1L || is.na(v) || !nzchar(v)) {
    griddy_abort("`", arg, "` must be a single non-empty string; received ",
                 paste(format(v), collapse = ", "), ".")
  }
  v
}

assert_flag <- function(v, arg) {
  if (!is.logical(v) || length(v) != 1L || is.na(v)) {
    griddy_abort("`", arg, "` must be TRUE or FALSE; received ",
                 paste(format(v), collapse = ", "), ".")
  }
  v
}

# A correlation grid: values in [0, 1).
assert_rho_grid <- function(v, arg) {
  v <- assert_numeric_vector(v, arg)
  bad <- v < 0 | v >= 1
  if (any(bad)) {
    griddy_abort("`", arg, "` must lie in [0, 1) (0 means independence); received ",
                 show_some(v[bad]), ".")
  }
  if (anyDuplicated(v)) {
    griddy_abort("`", arg, "` holds duplicated values: ", show_some(v[duplicated(v)]), ".")
  }
  v
}

# The Gamma prior on the precision tau.
assert_prior <- function(prior) {
  if (!is.list(prior) || is.null(prior$shape) || is.null(prior$rate)) {
    griddy_abort("`prior` must be a list with elements `shape` and `rate` ",
                 "(the Gamma prior on the precision tau).")
  }
  ok <- function(z) is.numeric(z) && length(z) == 1L && is.finite(z)
  if (!ok(prior$shape) || prior$shape <= 0) {
    griddy_abort("`prior$shape` must be a single positive number; received ",
                 paste(format(prior$shape), collapse = ", "), ".")
  }
  if (!ok(prior$rate) || prior$rate < 0) {
    griddy_abort("`prior$rate` must be a single number >= 0; received ",
                 paste(format(prior$rate), collapse = ", "), ".")
  }
  list(shape = as.double(prior$shape), rate = as.double(prior$rate))
}

# `len` finite numbers (any length when NULL) in [lower, upper]; either end
# may be open.
assert_number <- function(x, name, len = 1L, lower = -Inf, upper = Inf, lower_open = FALSE,
                          upper_open = FALSE) {
  if (!is.numeric(x) || (!is.null(len) && length(x) != len) || length(x) == 0L ||
      anyNA(x) || any(!is.finite(x)) || any(x < lower) || any(x > upper) ||
      (lower_open && any(x <= lower)) || (upper_open && any(x >= upper))) {
    what <- if (is.numeric(x)) paste(format(utils::head(x, 5)), collapse = ", ") else class(x)[1]
    rng <- paste0(if (lower_open) "(" else "[", lower, ", ", upper, if (upper_open) ")" else "]")
    griddy_abort("`", name, "` must be ", if (!is.null(len)) paste0(len, " ") else "",
                 "finite number", if (is.null(len) || len != 1L) "s" else "", " in ", rng,
                 "; received ", what, ".")
  }
  as.numeric(x)
}

# A probability strictly between 0 and 1 (an interval level, an FDR, ...).
assert_level <- function(level, arg = "level") {
  if (!is.numeric(level) || length(level) != 1L || !is.finite(level) || level <= 0 ||
      level >= 1) {
    griddy_abort("`", arg, "` must be a single number in (0, 1); received ",
                 paste(format(level), collapse = ", "), ".")
  }
  level
}
