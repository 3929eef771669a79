#' A full-factorial library of piston runs
#'
#' Evaluates [piston_model()] on a full-factorial grid of `n_per_dim` values
#' of each of the three heat-transfer coefficients over table 3.1's ranges
#' ([piston_htc_ranges()]) and returns it as a griddy [sim_library()].  The
#' thesis used 3 to 47 values per coefficient (27 to 103,823 runs): 3, 4, 5,
#' 6, 7, 8, 9, 10, 15, 22, 27, 32, 39 and 47, with 39 (59,319 runs) as its
#' working choice.
#'
#' The thesis ran its finite-element model 343 times to train a surrogate and
#' generated the rest of its library from the surrogate; this stand-in is
#' cheap enough (well under a millisecond per run) to be evaluated directly
#' for every run, so the library holds no surrogate error.
#'
#' Control settings x: one per output location (and operating condition).
#' `x` has columns `r` and `z`, the location's radius and height scaled by
#' the piston radius (65 mm) and height (50 mm), so both lie in \[0, 1\] and
#' distances suit a correlation like the thesis's eq. 3.14; with more than
#' one condition a third column `condition` holds the condition's row number
#' in [piston_conditions()] (1 = full load, 2 = part load).  The thesis used
#' 6, 15 and 27 locations (2, 5 or 9 per surface, see [piston_location_ids()])
#' and 54 data points, which we reproduce as the 27 locations under the two
#' operating conditions (`condition = c("full", "part")`); this reading of
#' "54" is our choice, the thesis does not say how its 54 points were made.
#'
#' @param n_per_dim Number of grid values per coefficient (whole number in
#'   2..60).
#' @param locations Ids of the output locations, see [piston_locations()];
#'   e.g. `piston_location_ids(2)` for the thesis's 6 data points.
#' @param condition Operating condition(s), see [piston_conditions()].
#' @param spacing `"linear"` (default, evenly spaced values as in the thesis)
#'   or `"log"` (evenly spaced on the log scale, which resolves the low end of
#'   the ~3 decades better).
#' @param ... Further arguments to [piston_model()], by name: `material`,
#'   `cell`, `gallery_gradient`, `conductivity_slope`.
#' @return A `sim_library` with `theta` a data.frame with columns
#'   `htc_undercrown`, `htc_gallery1`, `htc_gallery2` (W/m^2K; one row per
#'   run, the first coefficient varying fastest), `y` the
#'   `n_per_dim^3` x (locations x conditions) matrix of temperatures (deg C),
#'   `x` the settings described above and `t = NULL`.
#' @seealso [piston_model()], [piston_locations()], [sim_library()]
#' @family stand-in simulators
#' @export
#' @examples
#' lib <- piston_library(4, locations = piston_location_ids(2))
#' lib
piston_library <- function(n_per_dim = 7, locations = 1:27, condition = "full",
                           spacing = c("linear", "log"), ...) {
  n_per_dim <- assert_whole(n_per_dim, "n_per_dim", lower = 2, upper = 60)
  spacing <- assert_choice(spacing, "spacing", c("linear", "log"), vector_default = TRUE)
  locations <- assert_whole(locations, "locations", lower = 1, upper = 27, len = NULL,
                            distinct = TRUE)
  condition <- assert_choice(condition, "condition", piston_conditions()$condition,
                             several = TRUE)
  assert_dots(list(...), c("material", "cell", "gallery_gradient", "conductivity_slope"),
              "piston_model()")
  rng <- piston_htc_ranges()
  axes <- lapply(seq_len(nrow(rng)), function(j) {
    if (spacing == "linear") {
      seq(rng$min[j], rng$max[j], length.out = n_per_dim)
    } else {
      exp(seq(log(rng$min[j]), log(rng$max[j]), length.out = n_per_dim))
    }
  })
  names(axes) <- rng$parameter
  theta <- expand.grid(axes, KEEP.OUT.ATTRS = FALSE)
  y <- piston_model(as.matrix(theta), locations = locations, condition = condition, ...)
  sim_library(theta = theta, y = unname(y),
              x = piston_library_settings(locations, condition), t = NULL)
}

# The x settings of a piston library: scaled (r, z) of each location, plus the
# condition's number when there is more than one condition.
piston_library_settings <- function(locations, condition) {
  loc <- piston_locations(locations)
  all_cond <- piston_conditions()$condition
  do.call(rbind, lapply(condition, function(cond) {
    out <- data.frame(r = loc$r, z = loc$z)
    if (length(condition) > 1L) out$condition <- match(cond, all_cond)
    out
  }))
}
