#' Designs for a simulation campaign
#'
#' `design_lhs()` draws a Latin hypercube of `n` runs in a box: each
#' parameter's range is cut into `n` equal slices and every slice holds one
#' run, at a uniform place in it, the slices paired at random across
#' parameters (the design [refine()] draws in its rounds, from R's random
#' stream, so `set.seed()` or `seed` reproduces it). `design_grid()` is the
#' full-factorial grid of the values given for each parameter, the first
#' varying fastest. Either is a `design` for [simulate_library()].
#'
#' @param n The number of runs.
#' @param ... For `design_lhs()`, one named range `c(lower, upper)` per
#'   parameter; for `design_grid()`, one named numeric vector of values per
#'   parameter.
#' @param seed `NULL`, or a seed for this call only.
#' @return A data.frame with one column per parameter and one row per run.
#' @seealso [simulate_library()]
#' @examples
#' design_lhs(5, k = c(1, 4), c = c(0, 0.5), seed = 1)
#' design_grid(k = seq(1, 4, by = 1), c = c(0, 0.5))
#' @export
design_lhs <- function(n, ..., seed = NULL) {
  n <- assert_count(n, "n")
  seed <- assert_seed(seed)
  ranges <- named_arguments(list(...), "design_lhs")
  box <- vapply(names(ranges), function(name) {
    r <- assert_numeric_vector(ranges[[name]], name)
    if (length(r) != 2L || !(r[1] < r[2])) {
      griddy_abort("`", name, "` must be a range c(lower, upper) with lower < upper; ",
                   "received ", paste(format(r), collapse = ", "), ".")
    }
    r
  }, numeric(2))
  with_seed(seed, latin_hypercube(n, box, names(ranges)))
}

#' @rdname design_lhs
#' @export
design_grid <- function(...) {
  values <- named_arguments(list(...), "design_grid")
  values <- lapply(names(values), function(name) {
    v <- assert_numeric_vector(values[[name]], name)
    if (anyDuplicated(v)) griddy_abort("`", name, "` has repeated values.")
    v
  })
  grid <- expand.grid(values, KEEP.OUT.ATTRS = FALSE)
  names(grid) <- names(list(...))
  grid
}

named_arguments <- function(args, fun) {
  if (length(args) == 0L || is.null(names(args)) || any(names(args) == "") ||
      anyDuplicated(names(args))) {
    griddy_abort(fun, "() needs one argument per parameter, each named by its parameter ",
                 "(distinct names), such as `k = c(1, 4)`.")
  }
  args
}
