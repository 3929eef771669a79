#' Stand-in simulators: the thesis's piston and tyre
#'
#' Stewart (2023) calibrated two simulators that cannot ship with griddy: a
#' proprietary finite-element model of a piston crown's heat transfer
#' (chapters 3 and 4) and ADAMS/Car runs of a tyre rolling over a cleat
#' (chapter 5). griddy ships a small physical model in place of each, so that
#' the chapter vignettes can redo the thesis's studies, and the real-time and
#' gap-diagnosis vignettes have a simulator with known physics to work on.
#'
#' They are examples, not part of the calibration: [calibrate()], [refine()]
#' and the rest take a library of any simulator's runs ([sim_library()],
#' [simulate_library()]). Each stand-in comes with what the thesis's study
#' needs: the model, its parameter ranges, a library of runs and synthetic
#' field data made the way the thesis made them.
#'
#' * **The piston** (chapters 3 and 4): [piston_model()] gives crown
#'   temperatures at the 27 output locations of [piston_locations()] for
#'   three backside heat-transfer coefficients, with the ranges of
#'   [piston_htc_ranges()] under the operating conditions of
#'   [piston_conditions()]; [piston_heat_balance()] shows where the heat goes;
#'   [piston_library()] and [piston_field_data()] build the library and the
#'   measurements.
#' * **The tyre on a cleat** (chapter 5): [tyre_cleat_model()] gives the
#'   normal force of a wheel on the rig of [tyre_rig()] rolling over a cleat
#'   of the heights of [tyre_cleat_heights()], for the stiffness and damping
#'   ranges of [tyre_param_ranges()]; [tyre_library()] and
#'   [tyre_field_data()] build the library and the measurements.
#'
#' @references Stewart, H. (2023). Creation and Validation of a Novel Bayesian
#'   Calibration Method with Griddy Gibbs Sampling. MSc thesis, Clemson
#'   University. <https://tigerprints.clemson.edu/all_theses/4177/>
#' @family stand-in simulators
#' @name stand_in_simulators
NULL
