# Stand-in for the piston heat-transfer model of Stewart (2023), chapter 3:
# steady axisymmetric conduction in a piston crown with three unknown
# backside heat-transfer coefficients.  Equations and sources: ?piston_model.

# ---------------------------------------------------------------------------
# Fixed description of the piston (all lengths in mm, temperatures in deg C,
# heat-transfer coefficients in W/m^2K).  Engineering choices, see the docs of
# piston_model() for sources.
piston_spec <- function() {
  list(
    radius = 65, height = 50,                       # bore 130 mm, crown top z = 50
    crankcase = c(r_max = 50, z_max = 25),          # void under the crown
    undercrown_r_max = 44,                          # oil-jet cooled part of the underside
    undercrown_output_r_max = 44,                   # output locations on the undercrown
    gallery1 = c(r_min = 52, r_max = 59, z_min = 18, z_max = 36),  # outer gallery
    gallery2 = c(r_min = 34, r_max = 42, z_min = 30, z_max = 40),  # inner gallery
    ring_belt_z_min = 25,                           # outer wall above this is the ring belt
    t_fluid = c(undercrown = 110, gallery1 = 120, gallery2 = 120),
    ring = c(h = 800, t = 180),                     # ring belt to liner
    skirt = c(h = 300, t = 130),                    # skirt to liner (oil film)
    crankcase_bc = c(h = 300, t = 110),             # other crankcase-side surfaces
    gas_peak_r = 45, gas_peak_width = 10            # bowl-rim peak of the gas-side h
  )
}

#' Operating conditions of the piston stand-in
#'
#' The gas side of the crown is a convective (Robin) boundary with an
#' effective, cycle-averaged gas temperature `t_gas` and a heat-transfer
#' coefficient `h_gas` that peaks at the bowl rim (radius 45 mm):
#' \eqn{h_g(r) = h_{gas} (0.5 + \exp(-((r - 45)/10)^2))}{h_g(r) = h_gas * (0.5 + exp(-((r - 45 mm)/10 mm)^2))}.
#' Two conditions are defined, full load and part load; using both doubles
#' the 27 outputs to 54, like the thesis's largest data set.
#'
#' @return A data.frame with one row per condition and columns `condition`
#'   (name), `h_gas` (W/m^2K) and `t_gas` (deg C).
#' @seealso [piston_model()]
#' @family stand-in simulators
#' @export
#' @examples
#' piston_conditions()
piston_conditions <- function() {
  data.frame(condition = c("full", "part"),
             h_gas = c(900, 600),
             t_gas = c(950, 700),
             stringsAsFactors = FALSE)
}

#' Parameter ranges of the piston calibration (thesis table 3.1)
#'
#' @return A data.frame with one row per heat-transfer coefficient and columns
#'   `parameter`, `min`, `max` and `true` (W/m^2K), as in table 3.1 of
#'   Stewart (2023).
#' @family stand-in simulators
#' @export
#' @examples
#' piston_htc_ranges()
piston_htc_ranges <- function() {
  data.frame(parameter = c("htc_undercrown", "htc_gallery1", "htc_gallery2"),
             min = c(13.85, 8.61, 35.33),
             max = c(11984.70, 11977.45, 12002.49),
             true = c(1000, 3000, 2000),
             stringsAsFactors = FALSE)
}

# ---------------------------------------------------------------------------
# Mesh: structured r-z grid, finite volumes on the solid cells.
piston_mesh <- function(cell, conductivity) {
  sp <- piston_spec()
  d <- cell * 1e-3                                   # m
  nr <- as.integer(round(sp$radius / cell))
  nz <- as.integer(round(sp$height / cell))
  rc <- (seq_len(nr) - 0.5) * cell                   # mm, cell centres
  zc <- (seq_len(nz) - 0.5) * cell
  rr <- matrix(rc, nr, nz)
  zz <- matrix(zc, nr, nz, byrow = TRUE)
  inside <- function(b) rr > b[["r_min"]] & rr < b[["r_max"]] & zz > b[["z_min"]] & zz < b[["z_max"]]
  label <- matrix(0L, nr, nz)                        # 0 solid, 1 crankcase, 2/3 galleries
  label[rr < sp$crankcase[["r_max"]] & zz < sp$crankcase[["z_max"]]] <- 1L
  label[inside(sp$gallery1)] <- 2L
  label[inside(sp$gallery2)] <- 3L
  solid <- label == 0L
  # number solid cells with z fastest (column-major over the nr x nz matrix
  # is r fastest, so number over the transpose)
  id <- matrix(NA_integer_, nr, nz)
  id_t <- t(id)
  id_t[t(solid)] <- seq_len(sum(solid))
  id <- t(id_t)
  n <- sum(solid)
  k <- conductivity

  # internal faces
  pr <- which(solid[-nr, , drop = FALSE] & solid[-1, , drop = FALSE], arr.ind = TRUE)
  g_r <- 2 * pi * k * pr[, 1] * d                    # k (2 pi r_f d) / d, r_f = i d
  pz <- which(solid[, -nz, drop = FALSE] & solid[, -1, drop = FALSE], arr.ind = TRUE)
  g_z <- pi * k * (2 * pz[, 1] - 1) * d              # pi k (r_e^2 - r_w^2) / d
  pi_idx <- c(id[pr], id[pz])
  pj_idx <- c(id[cbind(pr[, 1] + 1L, pr[, 2])], id[cbind(pz[, 1], pz[, 2] + 1L)])
  g_int <- c(g_r, g_z)

  # boundary faces: one row per solid-cell face on a void or the domain edge
  sol <- which(solid, arr.ind = TRUE)
  si <- sol[, 1]
  sj <- sol[, 2]
  faces <- list()
  add <- function(sel, nb_label, area, r_f, z_f) {
    if (!any(sel)) return(NULL)
    data.frame(cell = id[cbind(si[sel], sj[sel])], nb = nb_label[sel],
               area = area[sel], r = r_f[sel], z = z_f[sel])
  }
  lab_at <- function(i, j) {
    out <- rep(-1L, length(i))                       # -1 = outside the domain
    ok <- i >= 1 & i <= nr & j >= 1 & j <= nz
    out[ok] <- label[cbind(i[ok], j[ok])]
    out
  }
  # east (r + d)
  nb <- lab_at(si + 1L, sj)
  faces$e <- add(nb != 0L, nb, 2 * pi * (si * d) * d, si * cell, rc[si] * 0 + zc[sj])
  # west (r - d); the axis (si == 1) has zero area and no face
  nb <- lab_at(si - 1L, sj)
  faces$w <- add(nb != 0L & si > 1L, nb, 2 * pi * ((si - 1) * d) * d, (si - 1) * cell, zc[sj])
  # north (z + d)
  nb <- lab_at(si, sj + 1L)
  faces$n <- add(nb != 0L, nb, pi * (2 * si - 1) * d^2, rc[si], sj * cell)
  # south (z - d)
  nb <- lab_at(si, sj - 1L)
  faces$s <- add(nb != 0L, nb, pi * (2 * si - 1) * d^2, rc[si], (sj - 1) * cell)
  bf <- do.call(rbind, faces)
  rownames(bf) <- NULL
  bf$dir <- rep(names(faces), vapply(faces, function(x) if (is.null(x)) 0L else nrow(x), 1L))

  # zone of each boundary face
  zone <- character(nrow(bf))
  zone[bf$nb == 2L] <- "gallery1"
  zone[bf$nb == 3L] <- "gallery2"
  cc <- bf$nb == 1L
  zone[cc] <- "crankcase"
  zone[cc & bf$dir == "s" & bf$r < sp$undercrown_r_max] <- "undercrown"
  out <- bf$nb == -1L
  zone[out & bf$dir == "n"] <- "gas"
  zone[out & bf$dir == "s"] <- "crankcase"           # skirt bottom edge
  zone[out & bf$dir == "e" & bf$z >= sp$ring_belt_z_min] <- "ring"
  zone[out & bf$dir == "e" & bf$z < sp$ring_belt_z_min] <- "skirt"
  bf$zone <- zone
  bf$rhalf <- (d / 2) / k                            # m^2K/W: half-cell resistance x area
  list(n = n, nr = nr, nz = nz, cell = cell, id = id, solid = solid,
       pair_i = pi_idx, pair_j = pj_idx, pair_g = g_int,
       bw = max(pj_idx - pi_idx), faces = bf, conductivity = k)
}

# Order of the faces of one HTC surface along the surface (arc length, mm).
piston_arc_length <- function(f, surface) {
  sp <- piston_spec()
  if (surface == "undercrown") return(f$r)
  b <- sp[[surface]]
  w <- b[["r_max"]] - b[["r_min"]]
  h <- b[["z_max"]] - b[["z_min"]]
  s <- numeric(nrow(f))
  bot <- f$dir == "n"                                # solid below the gallery: its floor
  rgt <- f$dir == "w"                                # solid right of the gallery
  top <- f$dir == "s"
  lft <- f$dir == "e"
  s[bot] <- f$r[bot] - b[["r_min"]]
  s[rgt] <- w + f$z[rgt] - b[["z_min"]]
  s[top] <- w + h + b[["r_max"]] - f$r[top]
  s[lft] <- 2 * w + h + b[["z_max"]] - f$z[lft]
  s
}

# Sum of `value` by integer index into a vector of length n.
piston_accumulate <- function(index, value, n) {
  s <- rowsum(value, index)
  out <- numeric(n)
  out[as.integer(rownames(s))] <- s[, 1]
  out
}

# Build (once per setting, cached) everything piston_model() needs.
piston_cache <- new.env(parent = emptyenv())

piston_setup <- function(condition, cell, material) {
  key <- paste(condition, cell, material, sep = "|")
  if (!is.null(piston_cache[[key]])) return(piston_cache[[key]])
  sp <- piston_spec()
  k <- c(steel = 42.6, aluminium = 134)[[material]]
  cond <- piston_conditions()
  cond <- cond[cond$condition == condition, ]
  m <- piston_mesh(cell, k)
  f <- m$faces
  # fixed Robin conductances
  h_fix <- rep(NA_real_, nrow(f))
  t_fix <- rep(NA_real_, nrow(f))
  gas <- f$zone == "gas"
  h_fix[gas] <- cond$h_gas * (0.5 + exp(-((f$r[gas] - sp$gas_peak_r) / sp$gas_peak_width)^2))
  t_fix[gas] <- cond$t_gas
  for (z in c("ring", "skirt", "crankcase")) {
    bc <- if (z == "crankcase") sp$crankcase_bc else sp[[z]]
    h_fix[f$zone == z] <- bc[["h"]]
    t_fix[f$zone == z] <- bc[["t"]]
  }
  fixed <- !is.na(h_fix)
  g_fix <- f$area * 0
  g_fix[fixed] <- f$area[fixed] / (f$rhalf[fixed] + 1 / h_fix[fixed])
  diag_fixed <- piston_accumulate(f$cell, g_fix, m$n)
  rhs_fixed <- piston_accumulate(f$cell, ifelse(fixed, g_fix * t_fix, 0), m$n)
  surfaces <- c("undercrown", "gallery1", "gallery2")
  htc_face <- which(f$zone %in% surfaces)
  s_cells <- sort(unique(f$cell[htc_face]))
  pre <- piston_precompute_cpp(m$n, m$bw, m$pair_i - 1L, m$pair_j - 1L, m$pair_g,
                               diag_fixed, rhs_fixed, s_cells - 1L)
  hf <- f[htc_face, ]
  hf$surface <- match(hf$zone, surfaces)
  hf$face_row <- htc_face
  hf$s_index <- match(hf$cell, s_cells)
  hf$arc <- 0
  for (s in surfaces) hf$arc[hf$zone == s] <- piston_arc_length(hf[hf$zone == s, ], s)
  # 9 output faces per surface, evenly spaced along the surface
  out <- integer(0)
  for (s in seq_along(surfaces)) {
    idx <- which(hf$surface == s)
    if (s == 1L) idx <- idx[hf$r[idx] <= sp$undercrown_output_r_max]
    a <- hf$arc[idx]
    lo <- min(a)
    hi <- max(a)
    target <- lo + (seq_len(9) - 0.5) / 9 * (hi - lo)
    pick <- vapply(target, function(x) idx[which.min(abs(a - x))], 1L)
    out <- c(out, pick)
  }
  res <- list(mesh = m, faces = f, fixed = fixed, g_fix = g_fix, t_fix = t_fix,
              Z = pre$Z, T0 = as.numeric(pre$T0), s_cells = s_cells,
              Zss = pre$Z[s_cells, , drop = FALSE], T0s = as.numeric(pre$T0)[s_cells],
              htc_faces = hf, out_faces = out,
              t_fluid = as.numeric(sp$t_fluid), condition = cond)
  assign(key, res, envir = piston_cache)
  res
}

# ---------------------------------------------------------------------------
# Argument checks (R validates with R/validate.R's helpers, C++ trusts its
# inputs).

# The coefficients as an N x 3 matrix of positive numbers.
piston_htc_matrix <- function(htc) {
  if (is.numeric(htc) && is.null(dim(htc)) && length(htc) != 3L) {
    griddy_abort("`htc` must have 3 values (undercrown, gallery 1, gallery 2); received ",
                 length(htc), ".")
  }
  htc <- as_numeric_matrix(htc, "htc", n_col = 3L, min_rows = 1L)
  assert_range(htc, "htc", lower = 0, lower_open = TRUE, unit = " (W/m^2K)")
  dimnames(htc) <- NULL
  htc
}

piston_materials <- c("steel", "aluminium")
piston_cells <- c(0.25, 0.5, 1)

#' Output locations of the piston stand-in
#'
#' The 27 temperature locations of [piston_model()]: 9 on each of the three
#' surfaces with an unknown heat-transfer coefficient (undercrown, cooling
#' gallery 1, cooling gallery 2), evenly spaced along each surface (by arc
#' length around the gallery walls, by radius on the undercrown), ordered
#' undercrown 1-9, gallery 1 1-9, gallery 2 1-9.  Their coordinates are the
#' control settings x of the calibration.
#'
#' `piston_location_ids()` picks `n_per_surface` of the 9 locations on each
#' surface, evenly spread and nested (2 -> the two ends, 5 -> every other
#' one), so 2, 5 and 9 per surface give the thesis's 6, 15 and 27 data points.
#'
#' @param locations Location ids (whole numbers in 1..27).
#' @param cell Grid cell size in mm (1, 0.5 or 0.25); locations snap to the
#'   faces of this grid.
#' @return `piston_locations()`: a data.frame with one row per location and
#'   columns `id`, `surface`, `index` (1-9 along the surface), `r_mm`, `z_mm`
#'   (face centre, mm) and `r`, `z` (the same divided by the piston radius
#'   65 mm and height 50 mm, i.e. in \[0, 1\]; these scaled values are the x
#'   settings used by [piston_library()]).
#'   `piston_location_ids()`: an integer vector of ids.
#' @seealso [piston_model()], [piston_library()]
#' @family stand-in simulators
#' @export
#' @examples
#' head(piston_locations())
#' piston_location_ids(2)
piston_locations <- function(locations = 1:27, cell = 1) {
  locations <- assert_whole(locations, "locations", lower = 1, upper = 27, len = NULL,
                            distinct = TRUE)
  cell <- assert_choice(cell, "cell", piston_cells)
  st <- piston_setup("full", cell, "steel")
  f <- st$htc_faces[st$out_faces[locations], ]
  sp <- piston_spec()
  data.frame(id = locations,
             surface = c("undercrown", "gallery1", "gallery2")[f$surface],
             index = (locations - 1L) %% 9L + 1L,
             r_mm = f$r, z_mm = f$z,
             r = f$r / sp$radius, z = f$z / sp$height,
             stringsAsFactors = FALSE)
}

#' @rdname piston_locations
#' @param n_per_surface Number of locations per surface, 1 to 9.
#' @export
piston_location_ids <- function(n_per_surface = 9) {
  n_per_surface <- assert_whole(n_per_surface, "n_per_surface", lower = 1, upper = 9)
  within <- if (n_per_surface == 1) 5L else as.integer(round(seq(1, 9, length.out = n_per_surface)))
  as.integer(c(within, within + 9L, within + 18L))
}

#' Piston crown temperatures for given backside heat-transfer coefficients
#'
#' A small physical stand-in for the proprietary finite-element piston model
#' of Stewart (2023, chapter 3): steady, axisymmetric heat conduction in a
#' steel monobloc piston crown (bore 130 mm, height 50 mm) with a crankcase
#' void under the crown and two rectangular cooling galleries, solved by
#' finite volumes on an r-z grid (`cell` mm squares).
#'
#' Boundary conditions: the crown top is a convective boundary to the
#' cycle-averaged combustion gas ([piston_conditions()]; a convective rather
#' than a flux boundary keeps temperatures bounded by the gas temperature
#' even when all three coefficients are at the bottom of their range); the
#' three unknown coefficients act on the undercrown (oil jet, 110 C, radius
#' < 44 mm), cooling gallery 1 (outer, r 52-59 mm, z 18-36 mm, oil 120 C)
#' and cooling gallery 2 (inner, r 34-42 mm, z 30-40 mm, oil 120 C); fixed
#' coefficients act on the ring belt (800 W/m^2K to 180 C), the skirt
#' (300 W/m^2K to 130 C) and the other crankcase-side surfaces (300 W/m^2K
#' to 110 C); the axis is a symmetry line.  Material: steel 42CrMo4,
#' k = 42.6 W/mK (Meusburger data sheet), or an aluminium piston alloy,
#' k = 134 W/mK (Meteor piston materials page).  The oil, ring-belt and gas
#' values are engineering assumptions in typical published ranges and are
#' not taken from the thesis, whose model
#' is not public.  Temperatures are the cycle-mean (steady) field, which is
#' what the thesis's "temporally averaged" temperatures are for a linear
#' problem.
#'
#' The conduction matrix with all fixed boundaries is assembled and factorised
#' once per `condition`, `cell` and `material` (cached for the session);
#' each set of coefficients then costs one dense solve of the size of the
#' number of grid cells touching the three surfaces (130 at `cell = 1`; about
#' 0.3 ms per set on one core).
#'
#' The thesis generated most of its simulation library from a surrogate
#' trained on 343 finite-element runs; this stand-in is cheap enough to be
#' evaluated directly for every run of the library.
#'
#' @param htc Heat-transfer coefficients in W/m^2K: a numeric vector of 3
#'   (undercrown, gallery 1, gallery 2) or an N x 3 matrix (or data.frame),
#'   one row per evaluation.
#' @param locations Ids (1..27) of the output locations, see
#'   [piston_locations()].
#' @param condition Operating condition(s), names from [piston_conditions()]:
#'   `"full"`, `"part"` or both.
#' @param material `"steel"` (default) or `"aluminium"`.
#' @param cell Grid cell size in mm: 1 (default), 0.5 or 0.25.
#' @param gallery_gradient Optional effect (off: 0): the coefficient of
#'   cooling gallery 1 varies linearly along the gallery wall,
#'   \eqn{h(s) = h_{gallery1} (1 + \beta (2 s / L - 1))} with `s` the arc
#'   length from the gallery floor's inner corner (see [piston_locations()])
#'   and `L` the wall's perimeter, so the mean coefficient is unchanged. A
#'   single value or one per row of `htc`, in (-1, 1).
#' @param conductivity_slope Optional effect (off: 0): a conductivity that
#'   varies with temperature, \eqn{k(T) = k_0 (1 + \alpha (T - 20))}, with
#'   \eqn{\alpha} in 1/K (steel: about -3e-4). It is applied through the
#'   Kirchhoff transform \eqn{U = T + \alpha (T - 20)^2 / 2}: the
#'   constant-conductivity solution is read as U and mapped back to T. This
#'   is exact for the conduction in the solid and for fixed-temperature
#'   boundaries, and an approximation at the convective boundaries (which act
#'   on T, not U); it is a stand-in for the effect, not a nonlinear solver. A
#'   single value or one per row of `htc`.
#' @return An N x (length(locations) * length(condition)) matrix of surface
#'   temperatures in deg C, one row per row of `htc`; columns in blocks by
#'   condition, locations in the given order within a block, named
#'   `"<condition>:<surface><index>"`.
#' @references Stewart, H. (2023). Creation and Validation of a Novel Bayesian
#'   Calibration Method with Griddy Gibbs Sampling. MSc thesis, Clemson
#'   University. <https://tigerprints.clemson.edu/all_theses/4177/>
#' @seealso [piston_locations()], [piston_library()], [piston_heat_balance()]
#' @family stand-in simulators
#' @export
#' @examples
#' piston_model(c(1000, 3000, 2000))[1, 1:5]
#' # one row per evaluation; temperatures fall as a coefficient rises
#' htc <- cbind(c(500, 1000, 2000), 3000, 2000)
#' piston_model(htc, locations = 1:3)
piston_model <- function(htc, locations = 1:27, condition = "full",
                         material = "steel", cell = 1, gallery_gradient = 0,
                         conductivity_slope = 0) {
  htc <- piston_htc_matrix(htc)
  gallery_gradient <- piston_effect(gallery_gradient, "gallery_gradient", nrow(htc), 1)
  conductivity_slope <- piston_effect(conductivity_slope, "conductivity_slope", nrow(htc),
                                      1e-3)
  locations <- assert_whole(locations, "locations", lower = 1, upper = 27, len = NULL,
                            distinct = TRUE)
  condition <- assert_choice(condition, "condition", piston_conditions()$condition,
                             several = TRUE)
  material <- assert_choice(material, "material", piston_materials)
  cell <- assert_choice(cell, "cell", piston_cells)
  blocks <- lapply(condition, function(cond) {
    st <- piston_setup(cond, cell, material)
    hf <- st$htc_faces
    out <- piston_eval_cpp(st$Zss, st$T0s, hf$s_index - 1L, hf$surface - 1L, hf$area,
                           hf$rhalf, st$t_fluid, htc, st$out_faces[locations] - 1L)
    graded <- which(gallery_gradient != 0)
    if (length(graded) > 0L) {
      out[graded, ] <- piston_eval_graded(st, htc[graded, , drop = FALSE],
                                          gallery_gradient[graded], locations)
    }
    kirchhoff_to_temperature(out, conductivity_slope)
  })
  out <- do.call(cbind, blocks)
  loc <- paste0(rep(c("undercrown", "gallery1", "gallery2"), each = 9), rep(1:9, 3))[locations]
  colnames(out) <- paste0(rep(condition, each = length(locations)), ":", loc)
  out
}

#' Heat balance and temperature field of the piston stand-in
#'
#' Solves [piston_model()]'s problem for one set of coefficients and returns
#' the heat flow through every boundary zone, plus (optionally) the whole
#' cell temperature field.  Heat in through the crown equals the heat out
#' through all other convective boundaries up to round-off; this is a check
#' of the solver and a convenient summary of where the heat goes.
#'
#' @inheritParams piston_model
#' @param htc A numeric vector of 3 coefficients (W/m^2K).
#' @param condition One operating condition, see [piston_conditions()].
#' @param field If `TRUE`, also return the temperature of every solid cell.
#' @return A list with `flows`, a data.frame with columns `zone` and `heat`
#'   (W, positive into the piston), `imbalance` (W, sum of all flows) and, if
#'   `field = TRUE`, `field`, a data.frame with columns `r_mm`, `z_mm` (cell
#'   centre) and `temperature` (deg C).
#' @family stand-in simulators
#' @export
#' @examples
#' piston_heat_balance(c(1000, 3000, 2000))$flows
piston_heat_balance <- function(htc, condition = "full", material = "steel",
                                cell = 1, field = FALSE) {
  htc <- piston_htc_matrix(htc)
  if (nrow(htc) != 1L) {
    griddy_abort("`htc` must be a single set of 3 coefficients; received ", nrow(htc),
                 " rows.")
  }
  condition <- assert_choice(condition, "condition", piston_conditions()$condition)
  material <- assert_choice(material, "material", piston_materials)
  cell <- assert_choice(cell, "cell", piston_cells)
  field <- assert_flag(field, "field")
  st <- piston_setup(condition, cell, material)
  hf <- st$htc_faces
  ts <- piston_eval_cpp(st$Zss, st$T0s, hf$s_index - 1L, hf$surface - 1L, hf$area,
                        hf$rhalf, st$t_fluid, htc, integer(0))[1, ]
  # full field: T = T0 + Z (w - G * T_S)
  g_face <- hf$area / (hf$rhalf + 1 / htc[1, hf$surface])
  gcell <- piston_accumulate(hf$s_index, g_face, length(st$s_cells))
  wcell <- piston_accumulate(hf$s_index, g_face * st$t_fluid[hf$surface], length(st$s_cells))
  tcell <- st$T0 + as.numeric(st$Z %*% (wcell - gcell * ts))
  f <- st$faces
  q <- numeric(nrow(f))                               # heat into the piston per face
  q[st$fixed] <- st$g_fix[st$fixed] * (st$t_fix[st$fixed] - tcell[f$cell[st$fixed]])
  hrow <- match(seq_len(nrow(f)), hf$face_row)
  is_htc <- !is.na(hrow)
  q[is_htc] <- g_face[hrow[is_htc]] * (st$t_fluid[hf$surface[hrow[is_htc]]] - tcell[f$cell[is_htc]])
  zones <- c("gas", "undercrown", "gallery1", "gallery2", "ring", "skirt", "crankcase")
  flows <- data.frame(zone = zones,
                      heat = vapply(zones, function(z) sum(q[f$zone == z]), 1.0),
                      stringsAsFactors = FALSE)
  rownames(flows) <- NULL
  out <- list(flows = flows, imbalance = sum(q))
  if (field) {
    m <- st$mesh
    pos <- which(m$solid, arr.ind = TRUE)
    ids <- m$id[pos]
    fld <- data.frame(r_mm = (pos[, 1] - 0.5) * m$cell, z_mm = (pos[, 2] - 0.5) * m$cell)
    fld$temperature <- tcell[ids]
    out$field <- fld[order(ids), ]
    rownames(out$field) <- NULL
  }
  out
}

# ---------------------------------------------------------------------------
# Optional effects of piston_model(); off (0) leaves the base model untouched.

# One value, or one per row of `htc` (n), in (-bound, bound).
piston_effect <- function(v, name, n, bound) {
  v <- assert_number(v, name, len = NULL, lower = -bound, upper = bound, lower_open = TRUE,
                     upper_open = TRUE)
  if (!(length(v) %in% c(1L, n))) {
    griddy_abort("`", name, "` must be one value or one per row of `htc` (", n, "); received ",
                 length(v), " values.")
  }
  rep_len(v, n)
}

# Face temperatures with the gallery-1 coefficient graded along the wall: the
# same surface-cell solve as piston_eval_cpp(), with one coefficient per face.
piston_eval_graded <- function(st, htc, beta, locations) {
  hf <- st$htc_faces
  g1 <- hf$surface == 2L
  len <- max(hf$arc[g1])
  shape <- ifelse(g1, 2 * hf$arc / len - 1, 0)
  ns <- length(st$s_cells)
  of <- st$out_faces[locations]
  t(vapply(seq_len(nrow(htc)), function(r) {
    h <- htc[r, hf$surface] * (1 + beta[r] * shape)
    g <- hf$area / (hf$rhalf + 1 / h)
    gcell <- piston_accumulate(hf$s_index, g, ns)
    wcell <- piston_accumulate(hf$s_index, g * st$t_fluid[hf$surface], ns)
    a <- st$Zss
    diag(a) <- diag(a) + 1 / gcell
    u <- solve(a, st$T0s + drop(st$Zss %*% wcell))
    ts <- u / gcell
    gk <- 1 / hf$rhalf[of]
    (gk * ts[hf$s_index[of]] + h[of] * st$t_fluid[hf$surface[of]]) / (gk + h[of])
  }, numeric(length(of))))
}

# Kirchhoff transform back from U = T + alpha (T - 20)^2 / 2 to T, per row.
# With alpha < 0, U has a maximum, 20 - 1 / (2 alpha), at T = 20 - 1 / alpha
# (where the conductivity reaches 0); a larger constant-conductivity
# temperature has no T, and is mapped to that T with a warning.
kirchhoff_to_temperature <- function(U, alpha) {
  on <- which(alpha != 0)
  if (length(on) == 0L) return(U)
  a <- alpha[on]
  du <- U[on, , drop = FALSE] - 20
  disc <- 1 + 2 * a * du
  beyond <- rowSums(disc < 0) > 0
  if (any(beyond)) {
    griddy_warn("`conductivity_slope` gives no solution for the temperature at some ",
                "locations of row(s) ", show_some(on[beyond]), " of `htc` (slope(s) ",
                show_some(a[beyond]), "): the conductivity k0 (1 + alpha (T - 20)) would ",
                "fall to 0 first; those temperatures are set to 20 - 1 / alpha, where it ",
                "does. Use a smaller |conductivity_slope| or larger coefficients.",
                class = "numeric")
  }
  U[on, ] <- 20 + (sqrt(pmax(disc, 0)) - 1) / a
  U
}
