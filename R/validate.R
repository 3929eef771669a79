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
#   package  a suggested package that the call needs is not installed;
#   unsupported  a combination of inputs a function does not yet handle.
# rlang::abort() (what cli::cli_abort() wraps) is called with the message as
# built, so it is never re-wrapped or re-interpolated: a message may hold
# braces and file paths, and reads in full in a log.
griddy_abort <- function(..., class = "input") {
  rlang::abort(paste0(...), class = c(paste0("griddy_error_", class), "griddy_error"),
               call = NULL)
}

# Warnings are classed the same way; base R's warningCondition() is enough
# here and costs a tenth of rlang::warn() (calibrate() may warn every call).
griddy_warn <- function(..., class = "general") {
  warning(warningCondition(paste0(...), class = c(paste0("griddy_warning_", class),
                                                  "griddy_warning"), call = NULL))
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
# columns and non-finite cells in the error. Integer and integer64 columns
# are read as numbers (see as_plain_numeric()). `n_col` (when not NULL) and
# `min_rows` check the shape.
as_numeric_matrix <- function(v, arg, n_col = NULL, min_rows = 0L) {
  if (is.data.frame(v)) {
    v <- as_numeric_columns(v, arg)
    bad <- names(v)[!vapply(v, is.numeric, logical(1))]
    if (length(bad) > 0L) {
      griddy_abort("`", arg, "` must be numeric; column(s) ", show_some(bad),
                   " are ", show_some(unique(vapply(v[bad], function(z) class(z)[1], ""))), ".")
    }
    v <- as.matrix(v)
    # a data.frame of 0 rows becomes a logical matrix, whatever its columns
    if (nrow(v) == 0L) storage.mode(v) <- "double"
  } else {
    v <- as_plain_numeric(v, arg)
    if (is.numeric(v) && is.null(dim(v))) {
      v <- matrix(v, nrow = 1L)
    }
  }
  if (!is.matrix(v) || !is.numeric(v)) {
    griddy_abort("`", arg, "` must be a numeric matrix or data.frame; received ",
                 class(v)[1], if (is.matrix(v)) paste0(" of type ", typeof(v)), ".")
  }
  if (!is.null(n_col) && ncol(v) != n_col) {
    griddy_abort("`", arg, "` must have ", n_col, " column(s); received ", nrow(v), " x ",
                 ncol(v), ".")
  }
  if (nrow(v) < min_rows) {
    griddy_abort("`", arg, "` must have at least ", min_rows, " row(s); received ", nrow(v),
                 ".")
  }
  storage.mode(v) <- "double"
  assert_finite(v, arg)
  v
}

# A number stored in a form that as.double() would misread, made a plain
# double (keeping dim and names): integer64 (package bit64; what
# data.table::fread() gives for whole numbers >= 2^31) stores its values as
# the bits of a double, which storage.mode<- and as.matrix() reinterpret as
# denormal garbage; bit64's as.double() method reads them right, and is
# registered as soon as bit64's namespace is loaded.
as_plain_numeric <- function(v, arg, bit64 = requireNamespace("bit64", quietly = TRUE)) {
  if (!inherits(v, "integer64")) {
    return(v)
  }
  if (!bit64) {
    griddy_abort("`", arg, "` is of class integer64 (whole numbers of 64 bits, e.g. from ",
                 "data.table::fread()), which package 'bit64' is needed to read, but it is ",
                 "not installed; install it with install.packages(\"bit64\"), or convert ",
                 "the values to double where they were read.", class = "package")
  }
  keep <- attributes(v)[intersect(names(attributes(v)), c("dim", "dimnames", "names"))]
  v <- as.double(v)
  attributes(v) <- keep
  v
}

# The columns of a data.frame with integer64 columns made plain doubles.
as_numeric_columns <- function(df, arg) {
  big <- vapply(df, inherits, logical(1), what = "integer64")
  for (j in which(big)) {
    df[[j]] <- as_plain_numeric(df[[j]], paste0(arg, "$", names(df)[j]))
  }
  df
}

# A data.frame (or matrix) with every column named and no name twice.
assert_column_names <- function(v, arg) {
  nm <- names(v)
  empty <- which(is.na(nm) | nm == "")
  if (length(empty) > 0L) {
    griddy_abort("`", arg, "` must have a name for every column; column(s) ",
                 show_some(empty), " have none.")
  }
  if (anyDuplicated(nm)) {
    griddy_abort("`", arg, "` has duplicated column names: ",
                 show_some(unique(nm[duplicated(nm)])), ".")
  }
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
  v <- as_plain_numeric(v, arg)
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

# Values (any shape) in [lower, upper], either end open; names the positions
# of the first values outside.
assert_range <- function(v, arg, lower = -Inf, upper = Inf, lower_open = FALSE,
                         upper_open = FALSE, unit = "") {
  bad <- v < lower | v > upper | (lower_open & v <= lower) | (upper_open & v >= upper)
  if (!any(bad)) {
    return(invisible(v))
  }
  pos <- which(bad, arr.ind = is.matrix(v))
  where <- if (is.matrix(pos)) paste0("[", pos[, 1], ", ", pos[, 2], "]") else paste0("[", pos, "]")
  griddy_abort("`", arg, "` must lie in ", format_range(lower, upper, lower_open, upper_open),
               unit, "; received ", show_some(v[bad]), " at ", show_some(where), ".")
}

format_range <- function(lower, upper, lower_open = FALSE, upper_open = FALSE) {
  paste0(if (lower_open) "(" else "[", lower, ", ", upper, if (upper_open) ")" else "]")
}

# Whole numbers in lower..upper, returned as integers. `len`: the number of
# values (NULL: one or more). Values that do not fit an integer (beyond
# +-.Machine$integer.max) are refused rather than turned into NA.
assert_whole <- function(v, arg, lower = 0, upper = .Machine$integer.max, len = 1L,
                         distinct = FALSE) {
  v <- as_plain_numeric(v, arg)
  upper <- min(upper, .Machine$integer.max)
  lower <- max(lower, -.Machine$integer.max)
  ok <- is.numeric(v) && length(v) >= 1L &&
    (is.null(len) || length(v) == len) && all(is.finite(v)) && all(v == round(v)) &&
    all(v >= lower) && all(v <= upper) && (!distinct || !anyDuplicated(v))
  if (!ok) {
    rng <- if (upper == .Machine$integer.max) {
      paste0(">= ", lower)
    } else {
      paste0("in ", lower, "..", upper)
    }
    if (is.numeric(v) && any(v > upper, na.rm = TRUE) && upper == .Machine$integer.max) {
      rng <- paste0(rng, " that fits an integer (at most ", upper, ")")
    }
    what <- if (is.numeric(v) || is.logical(v)) {
      if (length(v) == 0L) "nothing" else show_some(format(v, digits = 15))
    } else {
      class(v)[1]
    }
    griddy_abort("`", arg, "` must be ",
                 if (identical(len, 1L)) "a single whole number " else
                   paste0(if (!is.null(len)) paste0(len, " ") else "",
                          if (distinct) "distinct ", "whole numbers "),
                 rng, "; received ", what, ".")
  }
  as.integer(v)
}

# A count: one whole number >= min (and <= max).
assert_count <- function(v, arg, min = 1L, max = .Machine$integer.max) {
  assert_whole(v, arg, lower = min, upper = max)
}

# One of `choices` (or, with several = TRUE, one or more distinct of them);
# `choices` are strings or numbers. For an argument whose default is the
# vector of choices, vector_default = TRUE makes that vector mean the first,
# as with match.arg().
assert_choice <- function(v, arg, choices, several = FALSE, vector_default = FALSE) {
  if (vector_default && identical(v, choices)) {
    return(choices[1])
  }
  is_numbers <- is.numeric(choices)
  v <- if (is_numbers) as_plain_numeric(v, arg) else v
  same_type <- if (is_numbers) is.numeric(v) else is.character(v)
  ok <- same_type && is.null(dim(v)) && length(v) >= 1L && !anyNA(v) &&
    all(v %in% choices) && !anyDuplicated(v) && (several || length(v) == 1L)
  if (!ok) {
    quote <- function(z) if (is.character(z)) paste0("\"", z, "\"") else as.character(z)
    what <- if (same_type) {
      if (length(v) == 0L) "nothing" else show_some(quote(v))
    } else {
      paste0(class(v)[1], if (length(v) > 0L) paste0(" ", show_some(format(v))))
    }
    griddy_abort("`", arg, "` must be ", if (several) "one or more distinct of " else "one of ",
                 paste(quote(choices), collapse = ", "), "; received ", what, ".")
  }
  if (is_numbers) as.double(v) else v
}

# NULL (the current random stream) or a single whole number for set.seed().
assert_seed <- function(seed, arg = "seed") {
  if (is.null(seed)) {
    return(NULL)
  }
  assert_whole(seed, arg, lower = -.Machine$integer.max)
}

# The `...` a function passes on to `to`: every element named, and each name
# one of `allowed` (which `to` takes and the caller does not set itself).
assert_dots <- function(dots, allowed, to) {
  nm <- names(dots)
  if (is.null(nm)) nm <- rep("", length(dots))
  unnamed <- which(nm == "")
  if (length(unnamed) > 0L) {
    griddy_abort("The further arguments (`...`) to ", to, " must be named; argument(s) ",
                 show_some(unnamed), " of `...` are not. Allowed: ",
                 paste(allowed, collapse = ", "), ".")
  }
  bad <- setdiff(nm, allowed)
  if (length(bad) > 0L) {
    griddy_abort("The further arguments (`...`) to ", to, " may be ",
                 paste(allowed, collapse = ", "), "; received ", show_some(bad), ".")
  }
  if (anyDuplicated(nm)) {
    griddy_abort("The further arguments (`...`) to ", to, " name ",
                 show_some(unique(nm[duplicated(nm)])), " more than once.")
  }
  invisible(dots)
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
  prior$shape <- as_plain_numeric(prior$shape, "prior$shape")
  prior$rate <- as_plain_numeric(prior$rate, "prior$rate")
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
  x <- as_plain_numeric(x, name)
  if (!is.numeric(x) || (!is.null(len) && length(x) != len) || length(x) == 0L ||
      anyNA(x) || any(!is.finite(x)) || any(x < lower) || any(x > upper) ||
      (lower_open && any(x <= lower)) || (upper_open && any(x >= upper))) {
    what <- if (!is.numeric(x)) {
      class(x)[1]
    } else if (length(x) == 0L) {
      "nothing"
    } else {
      show_some(format(x))
    }
    rng <- format_range(lower, upper, lower_open, upper_open)
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

# The misfits C must be representable: with field data at a tiny scale
# (1e-300) the squared differences underflow to 0 or to denormals, and the
# precision tau ~ n / C overflows, so the posterior is uniform, infinite or
# NaN (it was reported as "a run reproduces the field data exactly", or
# reached the sampler as an internal error). Checked only when the field's
# scale makes it possible (C is as large as all of memory): at a field scale
# above 1e-100 a misfit this small means outputs equal to the field to 60
# digits, which the exact-reproduction check names.
assert_misfit_scale <- function(C, y_field, n_obs) {
  scale <- max(abs(y_field), na.rm = TRUE)
  if (!(scale > 0 && scale < 1e-100)) return(invisible(C))
  c_min <- min(C)
  if (c_min > n_obs * 1e-300) return(invisible(C))
  griddy_abort("The field data are at scale ", format(scale, digits = 3), " (largest |value|), ",
               "so the squared misfits between the runs and the field underflow double ",
               "precision (smallest misfit ", format(c_min, digits = 3), "; doubles end near ",
               "1e-308) and the noise precision tau ~ n / misfit overflows: the posterior ",
               "cannot be computed. Rescale the outputs and the field data by one common ",
               "factor (e.g. multiply both by ", format(10^-round(log10(scale)), digits = 3),
               ", or change their units) before calibrating.", class = "scale")
}

# predict()'s `run_mass`: the share of the posterior whose runs are
# simulated at new settings.
assert_run_mass <- function(run_mass) {
  if (!is.numeric(run_mass) || length(run_mass) != 1L || !is.finite(run_mass) ||
      run_mass <= 0 || run_mass > 1) {
    griddy_abort("`run_mass` must be a single number in (0, 1]; received ",
                 paste(format(run_mass), collapse = ", "), ".")
  }
  invisible(run_mass)
}
