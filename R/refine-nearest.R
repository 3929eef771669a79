# Nearest runs in scaled parameter space, for the library emulator
# (refine-emulator.R): which runs to read for a region, the k nearest runs to
# a point, and the runs' typical spacing. Brute force in blocks: the emulator
# searches among at most a region's runs, and no package for k-d trees is a
# dependency.

# The k nearest rows of `ref` to each row of `query` (both scaled, n x d):
# list(idx, dist), m x k matrices ordered by distance. With exclude_self, row i
# of query is row i of ref and is not its own neighbour (leave-one-out).
nearest_runs <- function(query, ref, k, exclude_self = FALSE) {
  m <- nrow(query)
  k <- min(k, nrow(ref) - exclude_self)
  idx <- matrix(0L, m, k)
  ref_sq <- rowSums(ref^2)
  # blocks of about 2e6 distances bound the memory of the distance matrix
  per_block <- max(1L, floor(2e6 / nrow(ref)))
  for (first in seq(1L, m, by = per_block)) {
    rows <- first:min(m, first + per_block - 1L)
    d2 <- outer(rowSums(query[rows, , drop = FALSE]^2), ref_sq, "+") -
      2 * tcrossprod(query[rows, , drop = FALSE], ref)
    if (exclude_self) d2[cbind(seq_along(rows), rows)] <- Inf
    # the nearest alone (as smallest_k(), the first of ties) without a call per row
    idx[rows, ] <- if (k == 1L) max.col(-d2, ties.method = "first") else
      t(apply(d2, 1, smallest_k, k = k))
  }
  # distances again, by differences: the expansion above loses the exact 0 at a run
  dist <- matrix(0, m, k)
  for (j in seq_len(ncol(query))) {
    dist <- dist + (query[, j] - matrix(ref[idx, j], m, k))^2
  }
  list(idx = idx, dist = sqrt(dist))
}

# Positions of the k smallest values of v, smallest first; a partial sort
# finds the k-th first, so a long v is not sorted whole.
smallest_k <- function(v, k) {
  if (length(v) > 4L * k) {
    cut <- sort.int(v, partial = k)[k]
    cand <- which(v <= cut)
    return(cand[order(v[cand])][seq_len(k)])
  }
  order(v)[seq_len(k)]
}

# Scaled distance of each row of u to the box (2 x d: lower, upper): 0 inside.
distance_to_box <- function(u, box) {
  below <- pmax(rep(box[1, ], each = nrow(u)) - u, 0)
  above <- pmax(u - rep(box[2, ], each = nrow(u)), 0)
  sqrt(rowSums((below + above)^2))
}

# At most n_max runs (rows of u) for a region: the runs nearest to the box;
# when more than n_max lie inside it, a spread-out subset of them (greedy
# maximin), so the emulator covers the whole box rather than its middle.
runs_for_region <- function(u, box, n_max) {
  dist <- distance_to_box(u, box)
  inside <- which(dist == 0)
  if (length(inside) <= n_max) {
    return(order(dist)[seq_len(min(n_max, nrow(u)))])
  }
  inside[sort(maximin_subset(u[inside, , drop = FALSE], n_max, start = colMeans(box)))]
}

# Greedy farthest-point subset of n rows of u, from the row nearest `start`.
maximin_subset <- function(u, n, start) {
  tu <- t(u)
  chosen <- integer(n)
  chosen[1] <- which.min(colSums((tu - start)^2))
  d2 <- colSums((tu - u[chosen[1], ])^2)
  for (i in seq_len(n)[-1]) {
    chosen[i] <- which.max(d2)
    d2 <- pmin(d2, colSums((tu - u[chosen[i], ])^2))
  }
  chosen
}

# Median distance from a run to its nearest other run, over at most 2000
# runs taken evenly (the median of a sample is enough for a scale).
median_nn_distance <- function(u) {
  if (nrow(u) < 2L) return(Inf)
  probe <- unique(round(seq(1, nrow(u), length.out = min(nrow(u), 2000L))))
  d <- if (length(probe) == nrow(u)) {
    nearest_runs(u, u, 1L, exclude_self = TRUE)$dist[, 1]
  } else {
    tu <- t(u)
    d2 <- vapply(probe, function(i) {
      v <- colSums((tu - u[i, ])^2)
      v[i] <- Inf
      min(v)
    }, numeric(1))
    sqrt(d2)
  }
  stats::median(d)
}

# n points of the Halton sequence in the box (2 x d): deterministic and
# spread out, to probe a region without touching the random number stream.
halton_in_box <- function(n, box) {
  primes <- c(2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71)
  d <- ncol(box)
  h <- vapply(seq_len(d), function(j) {
    b <- primes[(j - 1L) %% length(primes) + 1L]
    i <- seq_len(n)
    f <- 1
    r <- numeric(n)
    while (any(i > 0)) {
      f <- f / b
      r <- r + f * (i %% b)
      i <- i %/% b
    }
    r
  }, numeric(n))
  h <- matrix(h, n, d)
  rep(box[1, ], each = n) + h * rep(box[2, ] - box[1, ], each = n)
}

# The 2^d corners of the box (at most 2^10 of them) and its centre.
box_corners <- function(box) {
  d <- ncol(box)
  if (d > 10L) return(rbind(colMeans(box)))
  corners <- as.matrix(expand.grid(rep(list(1:2), d)))
  rbind(matrix(box[cbind(c(corners), rep(seq_len(d), each = nrow(corners)))],
               nrow(corners), d), colMeans(box))
}
