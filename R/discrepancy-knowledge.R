# What the user knows about the discrepancy: settings where delta is zero
# (`zero_at`) and where its slope over the x columns is zero (`flat_at`).
# Both are linear observations of the Gaussian process delta, observed
# without error and equal to 0, so the process given them is again a
# zero-mean Gaussian process with the kernel
#   K* = K - K[, Z] M^+ K[Z, ]
# (Z the stacked value and derivative observations, M their joint
# covariance): K* is just another covariance, so the engine and the
# evidence stay exact. Slopes are taken on the unit-scaled x columns the
# kernel uses; a zero slope is a zero slope on any scale.

# The user's knowledge checked against a library: NULL, or a data frame over
# the library's x columns (and t where it has several outputs per setting),
# finite numbers only. `arg` names it in errors.
assert_knowledge <- function(points, arg, library) {
  if (is.null(points)) return(NULL)
  x_names <- names(lib_x(library))
  several_t <- lib_n_t(library) > 1L
  allowed <- c(x_names, "t")
  unknown <- setdiff(names(points), allowed)
  if (length(unknown) > 0L) {
    griddy_abort("`", arg, "` has column(s) ", show_some(unknown), " that are not the ",
                 "library's x columns (", paste(x_names, collapse = ", "), ") or t.",
                 class = "input")
  }
  missing <- setdiff(x_names, names(points))
  if (length(missing) > 0L) {
    griddy_abort("`", arg, "` must give every x column of the library; it lacks ",
                 show_some(missing), ".", class = "input")
  }
  if (several_t && !"t" %in% names(points)) {
    griddy_abort("`", arg, "` must have a column `t`: the library has ", lib_n_t(library),
                 " outputs per x setting, so delta is known at a setting and an output ",
                 "coordinate (give one row per t where it holds for all).", class = "input")
  }
  points
}

# The shape checks that need no library (gp_discrepancy()): a data frame
# with at least one row of finite numbers.
assert_knowledge_frame <- function(points, arg) {
  if (is.null(points)) return(NULL)
  if (!is.data.frame(points) || nrow(points) == 0L || ncol(points) == 0L) {
    griddy_abort("`", arg, "` must be NULL or a data frame with at least one row, over the ",
                 "library's x columns (and t); received ", class(points)[1], ".",
                 class = "input")
  }
  bad <- names(points)[!vapply(points, function(v) is.numeric(v) && all(is.finite(v)), TRUE)]
  if (length(bad) > 0L) {
    griddy_abort("`", arg, "` must hold finite numbers; column(s) ", show_some(bad),
                 " do not.", class = "input")
  }
  points <- as.data.frame(lapply(points, as.numeric))
  rownames(points) <- NULL
  points
}

# Observations of delta on the kernel's coordinates: `u` the unit-scaled x
# columns (a matrix, one row per observation), `t` the scaled output
# coordinate and `d` what is observed: 0 the value, j the slope over x
# column j.
knowledge_observations <- function(library, zero_at, flat_at) {
  x <- lib_x(library)
  scale_like <- function(v, ref) {
    span <- max(ref) - min(ref)
    if (span > 0) (v - min(ref)) / span else v * 0
  }
  t_ref <- lib_t(library)
  one <- function(points, derivative) {
    if (is.null(points)) return(NULL)
    u <- vapply(names(x), function(nm) scale_like(points[[nm]], x[[nm]]), numeric(nrow(points)))
    u <- matrix(u, nrow(points), ncol(x))
    tt <- if ("t" %in% names(points)) scale_like(points$t, t_ref) else rep(0, nrow(points))
    if (!derivative) return(list(u = u, t = tt, d = rep(0L, nrow(points))))
    # the slope over every x column is zero: one observation per column
    j <- rep(seq_len(ncol(x)), each = nrow(points))
    rows <- rep(seq_len(nrow(points)), ncol(x))
    list(u = u[rows, , drop = FALSE], t = tt[rows], d = j)
  }
  obs <- Filter(Negate(is.null), list(one(zero_at, FALSE), one(flat_at, TRUE)))
  if (length(obs) == 0L) return(NULL)
  list(u = do.call(rbind, lapply(obs, `[[`, "u")), t = unlist(lapply(obs, `[[`, "t")),
       d = unlist(lapply(obs, `[[`, "d")))
}

# The library's outputs as observations of delta's value (library order:
# blocks of n_t per x setting).
cell_observations <- function(library) {
  x <- lib_x(library)
  u <- vapply(x, scale_unit, numeric(lib_n_x(library)))
  u <- matrix(u, lib_n_x(library), ncol(x))
  n_t <- lib_n_t(library)
  list(u = u[rep(seq_len(nrow(u)), each = n_t), , drop = FALSE],
       t = rep(scale_unit(lib_t(library)), nrow(u)), d = rep(0L, nrow(u) * n_t))
}

# The covariance between two sets of observations of delta under
# k = exp(-|u - u'|^2 / l_x^2) exp(-(t - t')^2 / l_t^2) (NA length: no such
# axis). With r = u_a - u_b: Cov(delta(a), d_m delta(b)) = k 2 r_m / l^2,
# Cov(d_j delta(a), delta(b)) = -k 2 r_j / l^2 and Cov(d_j delta(a),
# d_m delta(b)) = k (2 [j = m] / l^2 - 4 r_j r_m / l^4).
knowledge_cov <- function(a, b, length_x, length_t) {
  k <- matrix(1, length(a$d), length(b$d))
  if (!is.na(length_t)) k <- k * exp(-outer(a$t, b$t, "-")^2 / length_t^2)
  if (is.na(length_x)) {
    # no x axis: delta does not vary over x, so its slopes are 0
    return(k * outer(a$d == 0L, b$d == 0L))
  }
  p <- ncol(a$u)
  r <- lapply(seq_len(p), function(j) outer(a$u[, j], b$u[, j], "-"))
  k <- k * exp(-Reduce(`+`, lapply(r, `^`, 2)) / length_x^2)
  l2 <- length_x^2
  f <- matrix(0, length(a$d), length(b$d))
  f[outer(a$d == 0L, b$d == 0L, "&")] <- 1
  for (m in seq_len(p)) {
    sel <- outer(a$d == 0L, b$d == m, "&")
    f[sel] <- (2 * r[[m]] / l2)[sel]
    sel <- outer(a$d == m, b$d == 0L, "&")
    f[sel] <- (-2 * r[[m]] / l2)[sel]
    for (j in seq_len(p)) {
      sel <- outer(a$d == j, b$d == m, "&")
      f[sel] <- ((j == m) * 2 / l2 - 4 * r[[j]] * r[[m]] / l2^2)[sel]
    }
  }
  k * f
}

# K over the cells given delta's known zeros and zero slopes: the Gaussian
# conditional K - K_cZ M^+ K_Zc. M is inverted through its eigenvalues,
# dropping those below 1e-10 of the largest: repeated or redundant knowledge
# (the same point twice, points closer than the length scale resolves) adds
# nothing, and all of it is consistent (every observation is 0), so the
# pseudo-inverse is the exact conditional; no jitter is added.
condition_kernel <- function(K, cells, knowledge, length_x, length_t) {
  if (is.null(knowledge)) return(K)
  K_cz <- knowledge_cov(cells, knowledge, length_x, length_t)
  M <- knowledge_cov(knowledge, knowledge, length_x, length_t)
  e <- eigen((M + t(M)) / 2, symmetric = TRUE)
  keep <- e$values > 1e-10 * max(e$values, 0)
  if (!any(keep)) return(K)
  V <- K_cz %*% e$vectors[, keep, drop = FALSE]
  K_star <- K - V %*% (t(V) / e$values[keep])
  (K_star + t(K_star)) / 2
}
