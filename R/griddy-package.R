#' griddy: Bayesian calibration of computer models by Griddy Gibbs sampling
#'
#' Calibrates the unknown parameters \eqn{\theta} of a simulator against field
#' measurements by Griddy Gibbs sampling over a library of simulation runs
#' (Stewart, 2023). Start with [sim_library()] and [field_data()] (or
#' [read_calibration_inputs()] for the thesis's file layout), then
#' [calibrate()]; [posterior_exact()] gives the exact grid posterior.
#'
#' @keywords internal
#' @useDynLib griddy, .registration = TRUE
#' @importFrom Rcpp sourceCpp
#' @importFrom RcppArmadillo armadillo_version
#' @importFrom stats predict update
"_PACKAGE"

# ggplot2's computed variable in after_stat(density) (plot.griddy_fit)
utils::globalVariables("density")
