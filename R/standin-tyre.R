# Stand-in for the ADAMS/Car tyre test rig of Stewart (2023), chapter 5:
# one wheel on a constant-load rig rolling over a cleat.  Equations and
# sources: ?tyre_cleat_model.

# Arguments are checked with R/validate.R's helpers (R validates, C++ trusts
# its inputs).

#' Cleat heights of the tyre rig
#'
#' The thesis (section 5.1) lists cleat heights of 412, 274.4 and 121.3 mm
#' for a 100 mm long cleat.  These exceed the section height of a passenger
#' tyre (about 123 mm for the 205/60 R15-like tyre used here, unloaded radius
#' 313.5 mm) and 412 mm exceeds even the unloaded radius, so the wheel would
#' hit the cleat with its rim or hub; most likely the values slipped by a
#' factor of 10.  We therefore default to 41.2, 27.44 and 12.13 mm (typical
#' durability cleats) and keep the literal values as an option.  With the
#' literal values the tyre deflection exceeds the section height; use them
#' with `tyre_rig(bottoming = TRUE)` to add a rim-bottoming spring.  This is
#' a reconstruction decision, not a thesis fact.
#'
#' @param which `"rescaled"` (default, 41.2, 27.44, 12.13 mm) or
#'   `"thesis_literal"` (412, 274.4, 121.3 mm).
#' @return A numeric vector of three cleat heights in mm, in the thesis's order.
#' @seealso [tyre_cleat_model()]
#' @family stand-in simulators
#' @export
#' @examples
#' tyre_cleat_heights()
#' tyre_cleat_heights("thesis_literal")
tyre_cleat_heights <- function(which = c("rescaled", "thesis_literal")) {
  which <- assert_choice(which, "which", c("rescaled", "thesis_literal"), vector_default = TRUE)
  if (which == "rescaled") c(41.2, 27.44, 12.13) else c(412, 274.4, 121.3)
}

#' Parameter ranges of the tyre calibration (thesis table 5.1)
#'
#' @return A data.frame with columns `parameter` (`"k"`, vertical stiffness in
#'   N/mm; `"c"`, vertical damping in N s/mm), `min` and `max`.
#' @family stand-in simulators
#' @export
#' @examples
#' tyre_param_ranges()
tyre_param_ranges <- function() {
  data.frame(parameter = c("k", "c"), min = c(50, 0), max = c(800, 5),
             stringsAsFactors = FALSE)
}

#' Settings of the tyre rig and of the PAC2002-style vertical model
#'
#' `tyre_rig()` collects the rig, the wheel, the cleat and the numerics;
#' `tyre_pac2002()` the coefficients of the PAC2002-style vertical force that
#' the Fiala model does not have.  Defaults and their sources are listed in
#' [tyre_cleat_model()].
#'
#' @param load Constant vertical load of the rig, N (thesis: 3 kN).
#' @param mass Wheel and tyre mass, kg.
#' @param R0 Unloaded tyre radius, m.
#' @param rim_radius Rim radius, m (only used by `bottoming`).
#' @param cleat_length Cleat length, mm (thesis: 100 mm).
#' @param edge_length Length over which each cleat edge rises (half-cosine
#'   ramp), mm; must be > 0 and at most half the cleat length.
#' @param t_cleat Time at which the wheel centre reaches the cleat's leading
#'   edge, s.
#' @param n_samples Number of output samples (1 to 1e7).
#' @param sample_interval Time between output samples, s.
#' @param steps_per_sample Fixed RK4 steps per output sample (the internal
#'   step is `sample_interval / steps_per_sample`; 1 to 1e5); a step that
#'   holds a contact event is split there.
#' @param sample `"mean"` (default): each output is the average of Fz over
#'   the preceding sample interval (the impulse the integrator applied, over
#'   the interval's length); `"instant"`: Fz at the sample time, as a
#'   simulator would print it.
#' @param bottoming `TRUE` or `FALSE`: if `TRUE`, add a rim-bottoming spring of
#'   `bottom_stiffness` once the deflection exceeds the section height
#'   `R0 - rim_radius`.
#' @param bottom_stiffness Rim-bottoming stiffness, N/m.
#' @param patch_length Length of the rectangular contact patch of
#'   `contact = "patch"`, mm (> 0); `NULL` (default) takes, for each run, the
#'   chord that the flat road cuts from the unloaded tyre at its static
#'   deflection (see [tyre_patch_length()]).
#' @return A list of class `tyre_rig` or `tyre_pac2002`.
#' @seealso [tyre_cleat_model()]
#' @family stand-in simulators
#' @export
#' @examples
#' tyre_rig(sample = "instant")
#' tyre_pac2002(qFz2 = 0, qV2 = 0)
tyre_rig <- function(load = 3000, mass = 25, R0 = 0.3135, rim_radius = 0.1905,
                     cleat_length = 100, edge_length = 10, t_cleat = 0.02,
                     n_samples = 500, sample_interval = 1e-3, steps_per_sample = 100,
                     sample = c("mean", "instant"), bottoming = FALSE,
                     bottom_stiffness = 2e6, patch_length = NULL) {
  sample <- assert_choice(sample, "sample", c("mean", "instant"), vector_default = TRUE)
  out <- list(load = assert_number(load, "load", lower = 0, lower_open = TRUE),
              mass = assert_number(mass, "mass", lower = 0, lower_open = TRUE),
              R0 = assert_number(R0, "R0", lower = 0, lower_open = TRUE),
              rim_radius = assert_number(rim_radius, "rim_radius", lower = 0, lower_open = TRUE),
              cleat_length = assert_number(cleat_length, "cleat_length", lower = 0, lower_open = TRUE),
              edge_length = assert_number(edge_length, "edge_length", lower = 0, lower_open = TRUE),
              t_cleat = assert_number(t_cleat, "t_cleat", lower = 0),
              n_samples = assert_whole(n_samples, "n_samples", lower = 1, upper = 1e7),
              sample_interval = assert_number(sample_interval, "sample_interval", lower = 0,
                                         lower_open = TRUE),
              steps_per_sample = assert_whole(steps_per_sample, "steps_per_sample", lower = 1,
                                              upper = 1e5),
              sample = sample,
              bottoming = assert_flag(bottoming, "bottoming"),
              bottom_stiffness = assert_number(bottom_stiffness, "bottom_stiffness", lower = 0),
              patch_length = if (!is.null(patch_length)) {
                assert_number(patch_length, "patch_length", lower = 0, lower_open = TRUE)
              })
  if (out$rim_radius >= out$R0) {
    griddy_abort("`rim_radius` must be smaller than `R0`; received ", out$rim_radius, " >= ",
                 out$R0, ".")
  }
  if (out$edge_length > out$cleat_length / 2) {
    griddy_abort("`edge_length` must be at most half of `cleat_length` (",
                 out$cleat_length / 2, " mm); received ", out$edge_length, ".")
  }
  class(out) <- "tyre_rig"
  out
}

#' @rdname tyre_rig
#' @param qFz2 Quadratic vertical stiffness coefficient (off: 0).
#' @param qFz3 Camber dependence of the vertical stiffness (off: 0; only acts
#'   when `camber` is not 0).
#' @param qV2 Speed dependence of the vertical stiffness (off: 0).
#' @param qpFz1 Inflation-pressure dependence of the vertical stiffness (only
#'   acts when `pressure` differs from `p0`).
#' @param V0 Reference speed (LONGVL), m/s.
#' @param p0 Nominal inflation pressure, Pa.
#' @param Fz0 Nominal wheel load (FNOMIN), N.
#' @export
tyre_pac2002 <- function(qFz2 = 15, qFz3 = 0, qV2 = 0.034, qpFz1 = 0.88,
                         V0 = 16.6, p0 = 2.2e5, Fz0 = 4000) {
  out <- list(qFz2 = assert_number(qFz2, "qFz2", lower = 0),
              qFz3 = assert_number(qFz3, "qFz3", lower = 0),
              qV2 = assert_number(qV2, "qV2", lower = 0),
              qpFz1 = assert_number(qpFz1, "qpFz1"),
              V0 = assert_number(V0, "V0", lower = 0, lower_open = TRUE),
              p0 = assert_number(p0, "p0", lower = 0, lower_open = TRUE),
              Fz0 = assert_number(Fz0, "Fz0", lower = 0, lower_open = TRUE))
  class(out) <- "tyre_pac2002"
  out
}

# The operating arguments that tyre_cleat_model() and tyre_static_deflection()
# share, checked.
tyre_operating <- function(speed, camber, pressure, pac, rig) {
  if (!inherits(pac, "tyre_pac2002")) {
    griddy_abort("`pac` must come from tyre_pac2002(); received ", class(pac)[1], ".")
  }
  if (!inherits(rig, "tyre_rig")) {
    griddy_abort("`rig` must come from tyre_rig(); received ", class(rig)[1], ".")
  }
  if (is.null(pressure)) pressure <- pac$p0
  list(speed = assert_number(speed, "speed", lower = 0, lower_open = TRUE),
       camber = assert_number(camber, "camber", lower = -pi / 2, upper = pi / 2),
       pressure = assert_number(pressure, "pressure", lower = 0, lower_open = TRUE),
       pac = pac, rig = rig)
}

# Flatten everything into the SI list the C++ side reads.
tyre_settings <- function(model, contact, speed, camber, pressure, pac, rig) {
  dpi <- (pressure - pac$p0) / pac$p0
  if (model == "pac2002" && 1 + pac$qpFz1 * dpi <= 0) {
    griddy_abort("`pressure` gives a non-positive stiffness factor 1 + qpFz1 * dpi = ",
                 format(1 + pac$qpFz1 * dpi), "; received pressure = ", pressure, ".")
  }
  list(model = if (model == "fiala") 0L else 1L,
       contact = match(contact, tyre_contacts) - 1L,
       load = rig$load, speed = speed, mass = rig$mass, r0 = rig$R0, fz0 = pac$Fz0,
       qfz2 = pac$qFz2, qfz3 = pac$qFz3, qpfz1 = pac$qpFz1, qv2 = pac$qV2, v0 = pac$V0,
       camber = camber, dpi = dpi,
       cleat_length = rig$cleat_length / 1000, edge_length = rig$edge_length / 1000,
       t_cleat = rig$t_cleat, n_samples = rig$n_samples,
       steps_per_sample = rig$steps_per_sample, sample_interval = rig$sample_interval,
       sample_mean = rig$sample == "mean",
       bottom_stiffness = if (rig$bottoming) rig$bottom_stiffness else 0,
       bottom_deflection = rig$R0 - rig$rim_radius,
       patch_length = if (is.null(rig$patch_length)) 0 else rig$patch_length / 1000)
}

# The contact models, in the order of their codes in src/tyre_model.cpp.
tyre_contacts <- c("point", "disc", "patch")

# Fiala's contact is a rectangular patch of uniform pressure (thesis, sec.
# 5.1); PAC2002's a rigid disc (same place).
tyre_default_contact <- function(model) if (model == "fiala") "patch" else "disc"

#' Tyre normal force on a constant-load rig rolling over a cleat
#'
#' A small physical stand-in for the ADAMS/Car Tire Testrig "flat road with
#' cleat" runs of Stewart (2023, chapter 5): one wheel pressed on the road by
#' a constant load of 3 kN rolls at 20 m/s over a 100 mm long cleat.  The
#' vertical motion of the wheel centre is integrated with a fixed-step
#' fourth-order Runge-Kutta scheme in C++ (`m z'' = Fz - load`, start in
#' static equilibrium); the output is the vertical force Fz at `n_samples`
#' (500) samples, 1 ms apart, for each cleat height.
#'
#' **Contact events.** The force law changes its formula where the tyre
#' touches or leaves the road (the damping term makes the force jump there),
#' where it would pull on the road (clipped at 0), where the rim bottoms, and
#' where the rigid disc's contact point jumps from the flat road onto the
#' cleat or back.  Each such event is located within the time step (bisection
#' on the step length, to 1e-12 of a step) and the step is finished in the
#' new regime, so the outputs are continuous in `k` and `c` and the
#' likelihood of data is smooth in them.  (A plain fixed step put each event
#' at a stage evaluation, and the log likelihood of chapter 5's data jumped
#' by up to 11 units between values of k 0.005 N/mm apart;
#' `bench/tyre-contact.R`.)
#'
#' **Force laws.** Fiala: `Fn = k rho + c rho'` for tyre deflection
#' `rho > 0`, clipped at 0 (no tension), camber and pressure have no effect.
#' PAC2002-style (physics notes, 1.3):
#' `Fn = sV ((qFz1 + qFz3 gamma^2) rho/R0 + qFz2 (rho/R0)^2) (1 + qpFz1 dpi) Fz0 + c rho'`,
#' clipped at 0, with `qFz1 = k R0 / Fz0` (so `k` is the small-deflection
#' stiffness in both models), `sV = 1 + qV2 V / V0` (spin `|Omega| = V / R0`),
#' `gamma` the camber (rad) and `dpi = (pressure - p0) / p0`.  With
#' `qFz2 = 0`, `qV2 = 0`, `camber = 0` (or `qFz3 = 0`), `pressure = p0` and
#' point contact the PAC2002-style model equals Fiala with the same `k`.
#'
#' **Contact.** `"patch"` (default for Fiala): a rectangular contact patch
#' of uniform pressure, the thesis's Fiala assumption; see the section below.
#' `"point"`: a point follower under the wheel centre,
#' `rho = R0 - (z - h(x))`.  `"disc"` (default for PAC2002): the tyre is a
#' rigid disc; `rho` is `R0` minus the distance from the wheel centre to the
#' nearest road point, the force acts along the normal through that point
#' and Fz is its vertical component (the rig absorbs the longitudinal part).
#' The defaults follow the thesis (section 5.1): its Fiala model "assumes the
#' contact patch is rectangular and pressure is uniform across it", and its
#' PAC2002 model finds the contact patch "by assuming the tire acts as a
#' rigid disc".
#'
#' **Cleat edges and the damping spike.**  Under point contact the damping
#' term sees `rho' = V h'(x)`; on a sharp edge that is an impulse of about
#' `c * height` which a fixed step resolves differently each time, so
#' outputs would jump with the time step.  We therefore round the cleat
#' edges (each edge rises over `edge_length` = 10 mm with a half-cosine, so
#' the profile has a continuous slope) and, by default, report each sample as
#' the mean force over its 1 ms interval (`tyre_rig(sample = "mean")`), which
#' integrates the spike instead of sampling it.  The spike is real for a
#' point follower with damping: at k = 450 N/mm, c = 1.5 N s/mm the mean
#' force over the 1 ms that holds the edge of the 41.2 mm cleat is about
#' 75 kN, 25 times the static load (about 200 kN at c = 5 N s/mm).  Disc and
#' patch contact have no such spike.
#'
#' **Defaults and sources**: R0 = 0.3135 m
#' (205/60 R15: rim 0.1905 m + 0.6 x 0.205 m sidewall); wheel + tyre mass
#' 25 kg (tyre 17.45 kg in a public MF 6.1 .tir file, plus a rim; assumption);
#' Fz0 = 4000 N (between FNOMIN 3800 and 4850 N in public PAC2002 .tir files);
#' qFz2 = 15 (20.8 in the MF 6.1 file); qV2 = 0.034 and V0 = 16.6 m/s
#' (MF 6.1 file); qpFz1 = 0.88 (PFZ1 of the MF 6.1 file); p0 = 2.2 bar
#' (assumption); qFz3 = 0 (no public value; use 1-5 to switch it on,
#' assumption).  Load 3 kN, speed 20 m/s, cleat length 100 mm and the
#' ranges k 50-800 N/mm, c 0-5 N s/mm come from the thesis.  Cleat heights:
#' see [tyre_cleat_heights()].
#'
#' @section Contact patch of uniform pressure (`contact = "patch"`):
#' The patch is a rectangle of length `2a` (and some width `w`) centred under
#' the wheel, and the pressure `p` is the same everywhere on it, so
#' `Fz = 2 a w p`.  A uniform pressure carries one number for the whole
#' patch: the force cannot depend on the road point by point, only on one
#' measure of how far the patch is pressed in.  We take the patch mean: the
#' tyre's "elastic foundation" (the thesis's beam-on-an-elastic-foundation
#' picture) spreads the stiffness `k` evenly over the patch, each element
#' `dx` carrying `k dx / (2a)`, and the resultant is
#' `Fz = k rhobar + c rhobar'` with
#' `rhobar = R0 - (z - hbar(x))`, `hbar(x)` the mean road height over
#' `[x - a, x + a]`, and `rhobar' = -z' + V (h(x + a) - h(x - a)) / (2a)`.
#' This choice gives the static solution on a flat road (`hbar = 0`),
#' treats every point of the patch alike, and tends to the point follower
#' as `a -> 0` (`hbar -> h`, `hbar' -> h'`).  For the PAC2002-style law the
#' same `rhobar` enters its polynomial.
#'
#' What that means for the normal force over a cleat of height `h` and
#' length `L`:
#' * the cleat is felt from when the patch's front edge reaches it, `a`
#'   before the wheel centre does, until its rear edge leaves it;
#' * the spring force rises in proportion to the part of the cleat inside
#'   the patch, to at most `k h min(L, 2a) / (2a)`: a cleat shorter than the
#'   patch is enveloped and never felt at its full height (at k = 450 N/mm,
#'   `2a` = 129 mm and the 100 mm cleat is felt at 78% of its height);
#' * the road's rate seen by the damper is at most `V h / (2a)`, whatever the
#'   edge's shape, so the damping force over the cleat is bounded by
#'   `c V h / (2a)` (9.6 kN at k = 450 N/mm, c = 1.5 N s/mm on the 41.2 mm
#'   cleat) instead of the point follower's `c V h'(x)`, which grows without
#'   bound as the edge sharpens.
#'
#' **Patch length.** By default (`tyre_rig(patch_length = NULL)`) `2a` is the
#' chord that the flat road cuts from the unloaded tyre at its static
#' deflection `rho0`, `2a = 2 sqrt(2 R0 rho0 - rho0^2)`
#' ([tyre_patch_length()]): 97 mm at 800 N/mm, 129 mm at 450 N/mm, 369 mm at
#' 50 N/mm.  Altair MotionSolve's Fiala model takes the contact length of a
#' rigid disc of the unloaded radius when the tyre file gives no
#' contact-length coefficients (PA1, PA2; its "Tire Contact Methods" help
#' page); the thesis gives none.
#' It is fixed during a run: letting `a` follow the instantaneous
#' deflection would make the force a nonlinear function of the road even for
#' the linear Fiala spring, and a chord of a circle is not what the tyre
#' wraps round on a cleat anyway.  With a fixed `a` the contact is a moving
#' average of the road profile over the patch, a simpler relative of the
#' elliptical-cam enveloping of Adams's "3D Enveloping" contact.  Measured
#' footprints are shorter than the chord: the MF 6.1 contact-length law
#' `a = R0 (qRa2 rho / R0 + qRa1 sqrt(rho / R0))` with qRa1 = 0.601,
#' qRa2 = 0.820 (the public MF 6.1 .tir file) gives 66 mm at 450 N/mm,
#' about half.  Set `patch_length` to use another length.
#'
#' @param k Vertical stiffness in N/mm: a numeric vector (one value per run),
#'   or a matrix / data.frame with columns `k` and `c` (then `c` must be
#'   missing).
#' @param c Vertical damping in N s/mm, recycled with `k`.
#' @param height Cleat heights in mm (one or more); see [tyre_cleat_heights()].
#' @param model `"fiala"` or `"pac2002"`.
#' @param contact `"patch"` (rectangular patch of uniform pressure),
#'   `"point"` (point follower) or `"disc"` (rigid disc); `NULL` picks patch
#'   for Fiala and disc for PAC2002, as in the thesis.
#' @param speed Rolling speed, m/s.
#' @param camber Camber angle, rad (PAC2002 only, via `qFz3`).
#' @param pressure Inflation pressure, Pa (PAC2002 only, via `qpFz1`).
#' @param pac PAC2002-style coefficients, see [tyre_pac2002()].
#' @param rig Rig, cleat and numerical settings, see [tyre_rig()].
#' @return A numeric matrix of Fz (N) with one row per parameter set and
#'   `length(height) * n_samples` columns in blocks by height (500 columns
#'   for one height), with attributes `time` (the `n_samples` sample times in
#'   s; with `sample = "mean"` sample j is the mean over the interval ending
#'   at `time[j]`) and `height` (mm).
#' @references Stewart, H. (2023). Creation and Validation of a Novel Bayesian
#'   Calibration Method with Griddy Gibbs Sampling. MSc thesis, Clemson
#'   University. <https://tigerprints.clemson.edu/all_theses/4177/>
#' @seealso [tyre_library()], [tyre_rig()], [tyre_cleat_heights()]
#' @family stand-in simulators
#' @export
#' @examples
#' fz <- tyre_cleat_model(k = c(100, 210, 400), c = 0.5, height = 27.44)
#' dim(fz)
#' apply(fz, 1, max)
#' fz_pac <- tyre_cleat_model(210, 0.5, height = 27.44, model = "pac2002")
#' plot(attr(fz, "time"), fz[2, ], type = "l", xlab = "time (s)", ylab = "Fz (N)")
#' lines(attr(fz, "time"), fz_pac[1, ], col = 2)
tyre_cleat_model <- function(k = 210, c = 0.5, height = tyre_cleat_heights(),
                             model = c("fiala", "pac2002"), contact = NULL,
                             speed = 20, camber = 0, pressure = NULL,
                             pac = tyre_pac2002(), rig = tyre_rig()) {
  model <- assert_choice(model, "model", c("fiala", "pac2002"), vector_default = TRUE)
  if (is.matrix(k) || is.data.frame(k)) {
    if (!missing(c)) {
      griddy_abort("`c` must be missing when `k` is a matrix or data.frame of parameter rows.")
    }
    if (!all(c("k", "c") %in% colnames(k))) {
      griddy_abort("`k` given as a matrix or data.frame needs columns `k` and `c`; received ",
                   if (is.null(colnames(k))) "no column names" else show_some(colnames(k)), ".")
    }
    dup <- intersect(colnames(k)[duplicated(colnames(k))], c("k", "c"))
    if (length(dup) > 0L) {
      griddy_abort("`k` has duplicated column names: ", show_some(dup), ".")
    }
    kk <- k[, "k"]
    cc <- k[, "c"]
  } else {
    kk <- k
    cc <- c
  }
  kk <- assert_number(kk, "k", len = NULL, lower = 0, lower_open = TRUE)
  cc <- assert_number(cc, "c", len = NULL, lower = 0)
  n <- max(length(kk), length(cc))
  if (n %% length(kk) != 0L || n %% length(cc) != 0L) {
    griddy_abort("`k` (length ", length(kk), ") and `c` (length ", length(cc),
                 ") must have recyclable lengths.")
  }
  kk <- rep_len(kk, n)
  cc <- rep_len(cc, n)
  height <- assert_number(height, "height", len = NULL, lower = 0, lower_open = TRUE)
  if (is.null(contact)) contact <- tyre_default_contact(model)
  contact <- assert_choice(contact, "contact", tyre_contacts)
  op <- tyre_operating(speed, camber, pressure, pac, rig)
  rig <- op$rig
  if (max(height) / 1000 >= rig$R0) {
    griddy_warn("`height` ", max(height), " mm is not below the unloaded radius (",
                rig$R0 * 1000, " mm): the wheel is launched over the cleat.", class = "input")
  }
  s <- tyre_settings(model, contact, op$speed, op$camber, op$pressure, op$pac, rig)
  out <- tyre_sim_cpp(cbind(kk * 1000, cc * 1000), height / 1000, s)
  attr(out, "time") <- seq_len(rig$n_samples) * rig$sample_interval
  attr(out, "height") <- height
  out
}

#' @rdname tyre_cleat_model
#' @return `tyre_static_deflection()`: the static deflection in mm under the
#'   rig load for each `k`.
#' @export
tyre_static_deflection <- function(k = 210, model = c("fiala", "pac2002"), speed = 20,
                                   camber = 0, pressure = NULL, pac = tyre_pac2002(),
                                   rig = tyre_rig()) {
  st <- tyre_static_settings(k, model, speed, camber, pressure, pac, rig)
  as.numeric(tyre_static_deflection_cpp(st$k, st$settings)) * 1000
}

#' @rdname tyre_cleat_model
#' @return `tyre_patch_length()`: the length in mm of the rectangular contact
#'   patch of `contact = "patch"` for each `k`: `rig$patch_length` when set,
#'   otherwise `2 sqrt(2 R0 rho0 - rho0^2)` with `rho0` the static deflection.
#' @export
tyre_patch_length <- function(k = 210, model = c("fiala", "pac2002"), speed = 20,
                              camber = 0, pressure = NULL, pac = tyre_pac2002(),
                              rig = tyre_rig()) {
  st <- tyre_static_settings(k, model, speed, camber, pressure, pac, rig)
  as.numeric(tyre_patch_length_cpp(st$k, st$settings)) * 1000
}

# Checked stiffnesses (N/m) and the C++ settings of the tyre standing on the
# flat road, for the static quantities above.
tyre_static_settings <- function(k, model, speed, camber, pressure, pac, rig) {
  model <- assert_choice(model, "model", c("fiala", "pac2002"), vector_default = TRUE)
  k <- assert_number(k, "k", len = NULL, lower = 0, lower_open = TRUE)
  op <- tyre_operating(speed, camber, pressure, pac, rig)
  list(k = k * 1000,
       settings = tyre_settings(model, "patch", op$speed, op$camber, op$pressure, op$pac,
                                op$rig))
}
