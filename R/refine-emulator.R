# An emulator of the library: predicts a run's outputs at parameter values
# between the library's runs from the runs themselves, so that a calibration
# can refine its grid of theta without calling the simulator. Three methods,
# one file each:
#   "grid"   tensor-product cubic interpolation on a full-factorial library
#            (refine-emulator-grid.R);
#   "gp"     a parallel partial Gaussian process, RobustGaSP::ppgasp(), on at
#            most `max_runs` runs near the region (refine-emulator-gp.R);
#   "local"  local quadratic least squares on the nearest runs, needing no
#            other package (refine-emulator-local.R).
# "auto" takes "grid" for a full factorial, else "gp" when RobustGaSP is
# installed, else "local": the order bench/emulator-accuracy.R measured
# (bench/results/emulator-accuracy.md). For a dense library "auto" first
# tries a cheaper GP (see gp_emulator_dense()): when at least max_runs / 2
# runs lie inside the region, a GP on a maximin quarter of max_runs of them
# (cost cubic in the runs: 64 times less) is kept if it predicts the region's
# runs it did not use to 1e-3 of the outputs' spread; otherwise, and on every
# sparse design, the GP on max_runs runs as before. A local quadratic is no
# stand-in there: on a parameter with few distinct values its neighbours lie
# on one level and it falls back to a weighted mean (on
# bench/diagnose-gap-speed.R's "scale" region, held-out error 0.023 against
# the GP's 1.7e-8, outputs of sd 1).
#
# Internal: the refinement loop calls library_emulator(), emulator_predict()
# and emulator_loo() and validates the user's arguments, so the checks here
# are of shapes only.
#
# Distances: theta is scaled by the whole library's range per column,
# u = (theta - lower) / range, so that a region and its runs are measured
# alike whatever part of the library they cover (refine-nearest.R).

# library: any library backend (read through library.R only).
# region: NULL (the library's whole range) or two rows, lower and upper bounds
#   per parameter (a data.frame or matrix, columns named as the library's or
#   in its order); it is cut to the library's range. Predictions are asked
#   inside it, and only runs in or near it are read.
# max_runs: the most runs "gp" fits on (its cost grows with their cube).
# Returns a list of class griddy_emulator: `method`, `names`, `lower` and
# `range` (the scaling), `region` (see emulator_region()), `n_out`, `rows`
# (the library rows read), `y` (their outputs), `d_nn` (median scaled
# distance from a used run to its nearest neighbour) and the method's own
# fields.
library_emulator <- function(library, region = NULL,
                             method = c("auto", "grid", "gp", "local"), max_runs = 400) {
  method <- assert_choice(method, "method", c("auto", "grid", "gp", "local"),
                          vector_default = TRUE)
  max_runs <- assert_count(max_runs, "max_runs", min = 2L)
  if (!is_library(library)) {
    griddy_abort("`library` must be a griddy library; received ", class(library)[1], ".")
  }
  theta <- as.matrix(lib_theta(library))
  lower <- apply(theta, 2, min)
  upper <- apply(theta, 2, max)
  range <- upper - lower
  range[range == 0] <- 1  # distances along a constant column are 0 anyway
  base <- list(names = colnames(theta), lower = lower, range = range,
               region = emulator_region(region, colnames(theta), lower, upper, range),
               n_out = lib_n_out(library))
  grid <- if (method %in% c("auto", "grid")) grid_axes(theta)
  if (method == "grid" && is.null(grid)) {
    griddy_abort("method = \"grid\" needs a full-factorial library (every combination of ",
                 "the distinct values of each parameter, once); this one is not: use ",
                 "\"gp\" or \"local\".")
  }
  auto <- method == "auto"
  if (auto) {
    method <- if (!is.null(grid)) "grid" else
      if (requireNamespace("RobustGaSP", quietly = TRUE)) "gp" else "local"
  }
  dense <- if (auto && method == "gp") gp_emulator_dense(library, base, theta, max_runs)
  em <- if (!is.null(dense)) dense else switch(method,
    grid = grid_emulator(library, base, grid),
    gp = gp_emulator(library, base, theta, max_runs),
    local = local_emulator(library, base, theta)
  )
  em$method <- method
  class(em) <- "griddy_emulator"
  em
}

# Predictions at the rows of theta_new (a data.frame or matrix with the
# library's columns, by name when named), all inside the emulator's region:
# list(outputs = n_new x n_out matrix, rel_var = the prediction's variance
# relative to the largest it can be in the region, in [0, 1], 0 at a run).
# rel_var is, for "gp", ppgasp's predictive variance over its largest at a
# probe set of the region; for "grid" and "local" a distance measure (see
# distance_rel_var()). At a run every method returns the run's outputs.
emulator_predict <- function(emulator, theta_new) {
  pts <- emulator_points(emulator, theta_new)
  out <- switch(emulator$method,
    grid = grid_predict(emulator, pts),
    gp = gp_predict(emulator, pts),
    local = local_predict(emulator, pts)
  )
  dimnames(out$outputs) <- output_dimnames(emulator)
  out
}

# The emulator's errors on its own runs: list(rows = library rows, residuals =
# length(rows) x n_out matrix of output - prediction without that run).
# How they compare with the error between runs depends on the method
# (bench/results/emulator-accuracy.md): "grid"'s, predicted across a double
# gap, are 5-20 times larger; "local"'s and "gp"'s on scattered designs are
# within a factor of about 4; "gp"'s on a grid are unreliable (its
# correlation matrix is singular to working precision).
emulator_loo <- function(emulator) {
  out <- switch(emulator$method,
    grid = grid_loo(emulator),
    gp = gp_loo(emulator),
    local = local_loo(emulator)
  )
  dimnames(out$residuals) <- output_dimnames(emulator)
  out
}

# Results carry the outputs' names, if the library has them, and no run names.
output_dimnames <- function(emulator) {
  if (!is.null(colnames(emulator$y))) list(NULL, colnames(emulator$y))
}

# ---- region and points -------------------------------------------------------

# The region cut to the library's range (outside it every method would
# extrapolate): list(theta = 2 x d bounds in the parameters' units, u = the
# same scaled). The unscaled bounds are kept as given so that a bound on a
# grid node stays exactly on it.
emulator_region <- function(region, names, lower, upper, range) {
  box <- rbind(lower = lower, upper = upper)
  colnames(box) <- names
  if (!is.null(region)) {
    region <- align_columns(region, names, "region")
    if (nrow(region) != 2L) {
      griddy_abort("`region` must have two rows (lower and upper bounds); received ",
                   nrow(region), ".", class = "shape")
    }
    if (any(region[1, ] > region[2, ])) {
      griddy_abort("`region`'s lower bounds must not exceed its upper bounds; they do for ",
                   show_some(names[region[1, ] > region[2, ]]), ".")
    }
    apart <- region[2, ] < lower | region[1, ] > upper
    if (any(apart)) {
      griddy_abort("`region` lies outside the library's range in ", show_some(names[apart]),
                   ".")
    }
    box[1, ] <- pmax(region[1, ], lower)
    box[2, ] <- pmin(region[2, ], upper)
  }
  list(theta = box, u = (box - rep(lower, each = 2L)) / rep(range, each = 2L))
}

# A data.frame or matrix with the library's parameter columns, as a numeric
# matrix in the library's column order: matched by name when it has names,
# else taken in order.
align_columns <- function(v, names, arg) {
  v <- as_numeric_matrix(v, arg)
  if (is.null(colnames(v))) {
    if (ncol(v) != length(names)) {
      griddy_abort("`", arg, "` must have ", length(names), " columns (", show_some(names),
                   "); received ", ncol(v), ".", class = "shape")
    }
    colnames(v) <- names
  }
  if (!setequal(colnames(v), names) || ncol(v) != length(names)) {
    griddy_abort("`", arg, "` must have the library's columns ", show_some(names),
                 "; received ", show_some(colnames(v)), ".", class = "shape")
  }
  v[, names, drop = FALSE]
}

# New points: list(theta = in the parameters' units, u = scaled), each inside
# the region (to rounding), where the emulator was built to answer.
emulator_points <- function(emulator, theta_new) {
  theta <- align_columns(theta_new, emulator$names, "theta_new")
  n <- nrow(theta)
  box <- emulator$region$theta
  tol <- 1e-9 * rep(emulator$range, each = n)
  lo <- rep(box[1, ], each = n)
  hi <- rep(box[2, ], each = n)
  out <- theta < lo - tol | theta > hi + tol
  if (any(out)) {
    bad <- which(out, arr.ind = TRUE)
    griddy_abort("`theta_new` has point(s) outside the emulator's region: row(s) ",
                 show_some(unique(bad[, 1])), " in ",
                 show_some(unique(emulator$names[bad[, 2]])), ".")
  }
  # rounding past a bound is moved onto it, so no method extrapolates
  theta <- pmin(pmax(theta, lo), hi)
  list(theta = theta,
       u = (theta - rep(emulator$lower, each = n)) / rep(emulator$range, each = n))
}

# Theta (N x d) scaled by the library's ranges.
scale_theta <- function(theta, base) {
  (theta - rep(base$lower, each = nrow(theta))) / rep(base$range, each = nrow(theta))
}

# rel_var of "grid" and "local": (d / d_nn)^2, at most 1, where d is the
# scaled distance to the nearest used run; a cheap stand-in for a predictive
# variance that is 0 at a run and grows with the gap, on the scale of the
# runs' spacing.
distance_rel_var <- function(d, d_nn) {
  if (!is.finite(d_nn) || d_nn == 0) return(as.double(d > 0))
  pmin(1, (d / d_nn)^2)
}
