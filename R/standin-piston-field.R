#' Synthetic piston measurements as in the thesis's section 3.3
#'
#' Runs [piston_model()] at the true coefficients and adds the thesis's
#' measurement error, eq. 3.12, epsilon ~ MVN(0, 0.4 I), and optionally its
#' discrepancy, eq. 3.13-3.14, delta ~ MVN(0, 40 C) with
#' C_kl = prod_j 0.8^(4 (x_kj - x_lj)^2) over the scaled coordinates of the
#' output locations (the `x` of [piston_library()]).
#'
#' The noise and the discrepancy are drawn once for all 54 points (27
#' locations under the full- and part-load conditions) and then subset, so
#' the 6-, 15- and 27-point data sets are nested in the 54-point one and
#' differ only in how much of the same measurement campaign they see.  For
#' the 54 points the condition number (1 or 2) is a third x column, so the
#' discrepancy at the same location under the two conditions has correlation
#' 0.8^4 = 0.41: related but not the same, our reading of a discrepancy that
#' the thesis leaves unspecified across conditions.
#'
#' @param n_points Number of data points: 6, 15, 27 (2, 5 or 9 locations per
#'   surface at full load, [piston_location_ids()]) or 54 (all 27 locations
#'   at full and part load).
#' @param discrepancy Add the eq. 3.13 discrepancy? (`TRUE`/`FALSE`)
#' @param truth True coefficients (W/m^2K): undercrown, gallery 1, gallery 2.
#' @param noise_var,discrepancy_var Variances of the error and of the
#'   discrepancy (deg C^2).
#' @param rho Correlation parameter of the discrepancy, eq. 3.14.
#' @param seed Seed for the noise and discrepancy draws; `NULL` uses the
#'   current random stream.  The caller's stream is left as it was when a
#'   seed is given.
#' @return A [field_data()] object whose `x` matches
#'   `piston_library(..., locations, condition)` for the same `n_points`,
#'   with attributes `truth`, `clean` (the model at the truth), `noise`,
#'   `discrepancy` (zeros when `discrepancy = FALSE`), `locations` and
#'   `condition` (the arguments to give [piston_library()]).
#' @seealso [piston_library()], [calibrate()]
#' @family stand-in simulators
#' @export
#' @examples
#' f6 <- piston_field_data(6, seed = 1)
#' f6
#' lib <- piston_library(5, locations = attr(f6, "locations"))
#' fit <- calibrate(lib, f6, n_iter = 2000, burn_in = 500, seed = 1)
#' summary(fit)
piston_field_data <- function(n_points = 27, discrepancy = FALSE,
                              truth = c(1000, 3000, 2000), noise_var = 0.4,
                              discrepancy_var = 40, rho = 0.8, seed = NULL) {
  n_points <- assert_choice(n_points, "n_points", c(6, 15, 27, 54))
  assert_flag(discrepancy, "discrepancy")
  truth <- assert_number(truth, "truth", len = 3L, lower = 0, lower_open = TRUE)
  noise_var <- assert_number(noise_var, "noise_var", lower = 0)
  discrepancy_var <- assert_number(discrepancy_var, "discrepancy_var", lower = 0)
  rho <- assert_number(rho, "rho", lower = 0, upper = 1, lower_open = TRUE, upper_open = TRUE)
  seed <- assert_seed(seed)
  full <- piston_library_settings(1:27, c("full", "part"))
  draw <- function() {
    list(noise = stats::rnorm(54L, sd = sqrt(noise_var)),
         discrepancy = sqrt(discrepancy_var) *
           drop(crossprod(chol(corr_x(full, rep(rho, 3L))), stats::rnorm(54L))))
  }
  errors <- with_seed(seed, draw())
  design <- piston_data_design(n_points)
  keep <- match(paste(design$condition_id, design$location),
                paste(full$condition, rep(1:27, 2L)))
  clean <- drop(piston_model(truth, locations = design$locations,
                             condition = design$condition))
  delta <- if (discrepancy) errors$discrepancy[keep] else numeric(length(keep))
  x <- piston_library_settings(design$locations, design$condition)
  out <- field_data(unname(clean) + errors$noise[keep] + delta, x = x)
  structure(out, truth = stats::setNames(truth, piston_htc_ranges()$parameter),
            clean = unname(clean), noise = errors$noise[keep], discrepancy = delta,
            locations = design$locations, condition = design$condition)
}

# Which locations and conditions make up the thesis's 6, 15, 27 and 54 points.
piston_data_design <- function(n_points) {
  condition <- if (n_points == 54) c("full", "part") else "full"
  locations <- piston_location_ids(if (n_points == 54) 9 else n_points / 3)
  list(locations = locations, condition = condition,
       location = rep(locations, length(condition)),
       condition_id = rep(match(condition, piston_conditions()$condition),
                          each = length(locations)))
}
