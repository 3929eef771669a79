# A calibration problem for a test, by named arguments with calibrate()'s
# defaults (calibration_problem() takes them by position).
local_problem <- function(library, field, rho_x = 0, rho_t = 0, prior = NULL, x_power = 2,
                          run_weights = NULL, noise_groups = NULL, update = NULL,
                          discrepancy = NULL) {
  calibration_problem(library, field, rho_x, rho_t, prior, x_power, run_weights,
                      noise_groups = noise_groups, update = update, discrepancy = discrepancy)
}
