# A library of the tyre stand-in (standin-tyre.R) over a Latin hypercube of
# its two parameters.

#' A library of tyre-rig runs over a Latin hypercube of (k, c)
#'
#' Draws `n_runs` (k, c) combinations by Latin-hypercube sampling over
#' table 5.1's ranges (k 50-800 N/mm, c 0-5 N s/mm) with R's random number
#' generator (so `set.seed()` reproduces it), runs [tyre_cleat_model()] at
#' each of the cleat heights and returns a griddy `sim_library` with the
#' heights as control settings x and the sample times as output coordinates t.
#' The thesis used 2,000 combinations x 3 heights = 6,000 runs.
#'
#' @param n_runs Number of (k, c) combinations (a whole number >= 2).
#' @param height Cleat heights in mm (the x settings).
#' @param ranges Parameter ranges, a data.frame like [tyre_param_ranges()].
#' @param ... Further arguments to [tyre_cleat_model()], by name: `model`,
#'   `contact`, `speed`, `camber`, `pressure`, `pac`, `rig`.
#' @return A `sim_library` with `theta = data.frame(k, c)`, `y` an
#'   `n_runs` x (length(height) * 500) matrix in blocks by height,
#'   `x = data.frame(height)` and `t` the sample times.
#' @seealso [tyre_cleat_model()], [sim_library()]
#' @family stand-in simulators
#' @export
#' @examples
#' set.seed(1)
#' lib <- tyre_library(20)
tyre_library <- function(n_runs = 2000, height = tyre_cleat_heights(),
                         ranges = tyre_param_ranges(), ...) {
  n_runs <- assert_whole(n_runs, "n_runs", lower = 2)
  assert_dots(list(...), c("model", "contact", "speed", "camber", "pressure", "pac", "rig"),
              "tyre_cleat_model()")
  if (!is.data.frame(ranges) || !all(c("parameter", "min", "max") %in% names(ranges)) ||
      !all(c("k", "c") %in% ranges$parameter)) {
    griddy_abort("`ranges` must be a data.frame like tyre_param_ranges(), with columns ",
                 "parameter, min and max and rows for k and c; received ",
                 if (is.data.frame(ranges)) {
                   paste0("columns ", show_some(names(ranges)), " and parameter(s) ",
                          show_some(ranges$parameter))
                 } else {
                   class(ranges)[1]
                 }, ".")
  }
  twice <- intersect(ranges$parameter[duplicated(ranges$parameter)], c("k", "c"))
  if (length(twice) > 0L) {
    griddy_abort("`ranges` has more than one row for ", show_some(twice), ".")
  }
  rows <- match(c("k", "c"), ranges$parameter)
  lo <- assert_number(ranges$min[rows], "ranges$min", len = 2L)
  hi <- assert_number(ranges$max[rows], "ranges$max", len = 2L)
  if (any(hi <= lo) || lo[1] <= 0 || lo[2] < 0) {
    griddy_abort("`ranges` must have finite min < max, k > 0 and c >= 0; received k ",
                 lo[1], " to ", hi[1], ", c ", lo[2], " to ", hi[2], ".")
  }
  # Latin hypercube: one point in each of n_runs equal strata per dimension
  u <- vapply(1:2, function(j) (sample.int(n_runs) - stats::runif(n_runs)) / n_runs,
              numeric(n_runs))
  theta <- data.frame(k = lo[1] + u[, 1] * (hi[1] - lo[1]),
                      c = lo[2] + u[, 2] * (hi[2] - lo[2]))
  y <- tyre_cleat_model(as.matrix(theta), height = height, ...)
  tt <- attr(y, "time")
  attributes(y) <- list(dim = dim(y))
  sim_library(theta = theta, y = y, x = data.frame(height = height), t = tt)
}
