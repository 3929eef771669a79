#' Synthetic tyre-rig measurements as in the thesis's chapter 5
#'
#' Runs [tyre_cleat_model()] at one "true" parameter set (by default the
#' thesis's k = 450 N/mm, c = 1.5 N s/mm, which its library does not contain)
#' and adds independent Gaussian measurement noise to every sample, as the
#' thesis did to make its "experimental" data.
#'
#' The thesis does not state its noise level for chapter 5. The default,
#' `noise_sd = 60` N, is 2% of the rig's 3 kN static load: the order of the
#' accuracy of a wheel-force transducer or a rig load cell with a full scale of
#' tens of kN (our choice, documented in `vignette("chapter5")`). With
#' `model = "pac2002"` the same `k` and `c` drive the PAC2002-style model
#' (see [tyre_cleat_model()]), whose calibration by Fiala runs has no true
#' value.
#'
#' @param k,c True vertical stiffness (N/mm) and damping (N s/mm): one value
#'   each.
#' @param height Cleat heights in mm (the x settings of the library to
#'   calibrate).
#' @param model,contact Simulator that makes the data: see
#'   [tyre_cleat_model()].
#' @param noise_sd Standard deviation of the measurement noise, N
#'   (non-negative).
#' @param seed Seed for the noise draws; `NULL` uses the current random
#'   stream. The caller's stream is left as it was when a seed is given.
#' @param ... Further arguments to [tyre_cleat_model()], by name: `speed`,
#'   `camber`, `pressure`, `pac`, `rig`; give the library the same `rig`.
#' @return A [field_data()] object with `x = data.frame(height)` and `t` the
#'   sample times (s), matching [tyre_library()] with the same `height` and
#'   `rig`, with attributes `truth` (named `k`, `c`), `model`, `clean` (the
#'   noise-free signal, an `n_x x n_t` matrix), `noise` (same shape) and
#'   `noise_sd`.
#' @seealso [tyre_library()], [calibrate()]
#' @family stand-in simulators
#' @export
#' @examples
#' f <- tyre_field_data(height = 27.44, seed = 1)
#' f
#' attr(f, "truth")
#' sd(attr(f, "noise"))
#' set.seed(2)
#' lib <- tyre_library(60, height = 27.44)
#' fit <- calibrate(lib, f, n_iter = 1500, burn_in = 500, seed = 1)
#' summary(fit)
tyre_field_data <- function(k = 450, c = 1.5, height = tyre_cleat_heights(),
                            model = c("fiala", "pac2002"), contact = NULL,
                            noise_sd = 60, seed = NULL, ...) {
  model <- assert_choice(model, "model", c("fiala", "pac2002"), vector_default = TRUE)
  k <- assert_number(k, "k", lower = 0, lower_open = TRUE)
  c <- assert_number(c, "c", lower = 0)
  noise_sd <- assert_number(noise_sd, "noise_sd", lower = 0)
  seed <- assert_seed(seed)
  assert_dots(list(...), c("speed", "camber", "pressure", "pac", "rig"), "tyre_cleat_model()")
  clean <- tyre_cleat_model(k, c, height = height, model = model, contact = contact, ...)
  tt <- attr(clean, "time")
  height <- attr(clean, "height")
  clean <- matrix(as.vector(clean), nrow = length(height), byrow = TRUE)
  draw <- function() matrix(stats::rnorm(length(clean), sd = noise_sd), nrow(clean))
  noise <- with_seed(seed, draw())
  out <- field_data(clean + noise, x = data.frame(height = height), t = tt)
  structure(out, truth = c(k = k, c = c), model = model, clean = clean, noise = noise,
            noise_sd = noise_sd)
}
