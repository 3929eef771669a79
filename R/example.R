#' A small example: a damped spring-mass released from rest
#'
#' A library of 441 runs of an analytic simulator, a spring-mass-damper
#' released from a 10 mm deflection, over a 21 x 21 grid of stiffness `k`
#' (500 to 2000 N/m) and damping `c` (2 to 20 N s/m), at three masses (the x
#' settings: 1, 2 and 4 kg), with the displacement (mm) at 30 times from 0 to
#' 1.5 s. The field data come from the same simulator at `k = 1234`,
#' `c = 7.7` (between the grid points) with Gaussian noise of sd 1.5 mm.
#' The files under `system.file("extdata", package = "griddy")` are in the
#' thesis's `design` / `simobs` / `expobs` layout; `data-raw/oscillator.R` in
#' the package sources writes them.
#'
#' @return A list with `library` (a [sim_library()]), `field` (a
#'   [field_data()]) and `truth` (the named true parameter values).
#' @examples
#' ex <- griddy_example()
#' ex$library
#' ex$truth
#' @export
griddy_example <- function() {
  dir <- system.file("extdata", package = "griddy", mustWork = TRUE)
  inputs <- read_calibration_inputs(
    design = file.path(dir, "oscillator_design.csv"),
    simobs = file.path(dir, "oscillator_simobs.csv"),
    expobs = file.path(dir, "oscillator_expobs.csv"),
    n_x = 1,
    t = seq(0, 1.5, length.out = 30)
  )
  truth <- data.table::fread(file.path(dir, "oscillator_truth.csv"), data.table = FALSE)
  c(inputs, list(truth = unlist(truth[1, ])))
}
