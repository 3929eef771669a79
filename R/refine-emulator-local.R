# The "local" library emulator (see refine-emulator.R), which needs no other
# package: at each new point, a weighted least-squares quadratic in theta
# (linear, or a weighted mean, when too few runs) fitted to the k nearest
# runs, its value at the point the prediction. Tricube weights on the
# distance make the prediction continuous as the neighbours change. At a run
# it returns the run itself.

# The quadratic's coefficients in d parameters, and how many neighbours
# fit it: twice as many. On the Latin hypercubes of bench/emulator-accuracy.R
# (projectile 343 runs, oscillator 625, piston 343), factors 2 and 3 gave the
# smallest held-out errors, 1.5 up to twice as large, 1.2 (barely more runs
# than coefficients) 10 to 50 times (see bench/results/emulator-accuracy.md).
local_n_coef <- function(d, degree) {
  switch(degree + 1L, 1L, d + 1L, (d + 1L) * (d + 2L) %/% 2L)
}
local_k_factor <- 2

# Reads the runs within reach of the region: those no farther from it than
# the k-th nearest run is from its corners and centre.
local_emulator <- function(library, base, theta) {
  u_all <- scale_theta(theta, base)
  d <- ncol(u_all)
  k <- min(nrow(u_all), ceiling(local_k_factor * local_n_coef(d, 2L)))
  box <- base$region$u
  reach <- max(nearest_runs(box_corners(box), u_all, k)$dist[, k])
  rows <- which(distance_to_box(u_all, box) <= reach)
  em <- c(base, list(rows = rows, u = u_all[rows, , drop = FALSE],
                     y = lib_outputs(library, rows), k = k))
  em$d_nn <- median_nn_distance(em$u)
  em
}

local_predict <- function(emulator, pts) {
  near <- nearest_runs(pts$u, emulator$u, emulator$k)
  out <- local_fits(emulator, pts$u, near)
  at_run <- near$dist[, 1] == 0
  out[at_run, ] <- emulator$y[near$idx[at_run, 1], ]
  list(outputs = out, rel_var = distance_rel_var(near$dist[, 1], emulator$d_nn))
}

# Each used run predicted from its k nearest other runs.
local_loo <- function(emulator) {
  near <- nearest_runs(emulator$u, emulator$u, emulator$k, exclude_self = TRUE)
  list(rows = emulator$rows, residuals = emulator$y - local_fits(emulator, emulator$u, near))
}

# The local fit's value at each row of u, given its neighbours (see
# nearest_runs()).
local_fits <- function(emulator, u, near) {
  out <- matrix(0, nrow(u), ncol(emulator$y))
  for (i in seq_len(nrow(u))) {
    nb <- near$idx[i, ]
    out[i, ] <- local_fit_at(u[i, ], emulator$u[nb, , drop = FALSE],
                             emulator$y[nb, , drop = FALSE], near$dist[i, ])
  }
  out
}

# Weighted least squares centred on u0, so the intercept is the prediction;
# coordinates divided by the bandwidth h keep the design well scaled. The
# degree drops when the neighbours cannot determine the quadratic (too few,
# or on a lower-dimensional set).
local_fit_at <- function(u0, nb_u, nb_y, nb_d) {
  h <- 1.2 * max(nb_d)
  if (h == 0) return(colMeans(nb_y))
  w <- sqrt((1 - (nb_d / h)^3)^3)
  z <- (nb_u - rep(u0, each = nrow(nb_u))) / h
  for (degree in 2:0) {
    if (nrow(nb_u) < local_n_coef(ncol(nb_u), degree) + 1L && degree > 0L) next
    x <- local_design(z, degree)
    fit <- qr(w * x)
    if (fit$rank == ncol(x)) return(qr.coef(fit, w * nb_y)[1, ])
  }
  colSums(w^2 * nb_y) / sum(w^2)
}

# Columns 1, z_j and, for degree 2, z_j z_l (l >= j).
local_design <- function(z, degree) {
  x <- matrix(1, nrow(z), 1L)
  if (degree >= 1L) x <- cbind(x, z)
  if (degree >= 2L) {
    for (j in seq_len(ncol(z))) x <- cbind(x, z[, j] * z[, j:ncol(z), drop = FALSE])
  }
  x
}
