# The "grid" library emulator (see refine-emulator.R): on a full-factorial
# library, tensor-product piecewise-cubic interpolation. Along each axis a
# point is interpolated by the Lagrange polynomial through the 4 nodes around
# it (the 2 below and the 2 above), fewer at the ends of the axis (3, or 2
# on an axis of 2 nodes); the tensor product of the axes' weights gives up to
# 4^p runs per point. It is exact at nodes, reproduces cubics inside the
# grid, and needs no fit: a prediction is a sparse weight matrix (new points
# x runs, 4^p entries a row, held as index and weight matrices, the ELLPACK
# layout) times the runs' outputs.

# The axes of a full-factorial theta (N x p matrix, rows in any order), or
# NULL when it is not one: list(axes = each column's distinct values sorted,
# sizes, row_of_key = the library row at each grid key, the key of node
# (i_1, ..., i_p) being 1 + sum((i_j - 1) * stride_j), the first axis
# fastest).
grid_axes <- function(theta) {
  axes <- lapply(seq_len(ncol(theta)), function(j) sort(unique(theta[, j])))
  sizes <- lengths(axes)
  if (prod(sizes) != nrow(theta)) return(NULL)
  index <- vapply(seq_along(axes), function(j) match(theta[, j], axes[[j]]),
                  integer(nrow(theta)))
  key <- drop((matrix(index, nrow(theta)) - 1) %*% grid_strides(sizes)) + 1
  if (anyDuplicated(key)) return(NULL)
  row_of_key <- integer(nrow(theta))
  row_of_key[key] <- seq_len(nrow(theta))
  list(axes = axes, sizes = sizes, row_of_key = row_of_key)
}

grid_strides <- function(sizes) cumprod(c(1, sizes[-length(sizes)]))

# Keys (1-based) of every node of a sub-grid given per axis as node indices
# `index[[j]]` into a grid of `sizes`, the first axis fastest.
grid_keys <- function(index, sizes) {
  strides <- grid_strides(sizes)
  key <- 1
  for (j in seq_along(index)) {
    key <- rep(key, times = length(index[[j]])) +
      rep((index[[j]] - 1) * strides[j], each = length(key))
  }
  key
}

# Reads the runs of the cells that touch the region, with the 2 nodes on each
# side that the leave-one-out stencils of their nodes reach (interpolation
# stencils reach 1): a sub-grid, whose outputs are stored in its own key
# order.
grid_emulator <- function(library, base, grid) {
  box <- base$region$theta
  cells <- lapply(seq_along(grid$axes), function(j) {
    x <- grid$axes[[j]]
    if (length(x) == 1L) return(c(1L, 1L))
    first <- findInterval(box[1, j], x, rightmost.closed = TRUE, all.inside = TRUE)
    last <- findInterval(box[2, j], x, rightmost.closed = TRUE, all.inside = TRUE)
    c(first, last + 1L)  # the first and last nodes of the touching cells
  })
  keep <- lapply(seq_along(cells), function(j) {
    max(1L, cells[[j]][1] - 2L):min(grid$sizes[j], cells[[j]][2] + 2L)
  })
  rows <- grid$row_of_key[grid_keys(keep, grid$sizes)]
  em <- c(base, list(axes = grid$axes, keep = keep,
                     loo = lapply(cells, function(r) r[1]:r[2]),
                     rows = rows, y = lib_outputs(library, rows)))
  em$d_nn <- grid_median_spacing(em)
  em
}

# Predictions at pts (see emulator_points()).
grid_predict <- function(emulator, pts) {
  theta <- pts$theta
  stencils <- lapply(seq_along(emulator$axes), function(j) {
    x <- emulator$axes[[j]]
    index <- axis_stencil(x, theta[, j])
    list(index = index, weight = lagrange_weights(x, index, theta[, j]))
  })
  list(outputs = grid_apply(emulator, stencils),
       rel_var = distance_rel_var(grid_nearest_distance(emulator, theta), emulator$d_nn))
}

# Each node of the cells touching the region predicted from the tensor
# stencil of its axes' 2 nodes below and 2 above, so no run on a line or
# plane through it: Lagrange interpolation across a gap of twice the spacing,
# a conservative measure of the error between nodes.
grid_loo <- function(emulator) {
  per_axis <- lapply(seq_along(emulator$axes), function(j) {
    x <- emulator$axes[[j]]
    i <- emulator$loo[[j]]
    index <- axis_loo_stencil(length(x), i)
    list(index = index, weight = lagrange_weights(x, index, x[i]))
  })
  # every node of the tensor product of the axes' nodes: its row in each table
  at <- as.matrix(expand.grid(lapply(emulator$loo, seq_along), KEEP.OUT.ATTRS = FALSE))
  stencils <- lapply(seq_along(per_axis), function(j) {
    list(index = per_axis[[j]]$index[at[, j], , drop = FALSE],
         weight = per_axis[[j]]$weight[at[, j], , drop = FALSE])
  })
  local <- lapply(seq_along(emulator$loo), function(j) {
    emulator$loo[[j]] - emulator$keep[[j]][1] + 1L
  })
  own <- grid_keys(local, lengths(emulator$keep))
  list(rows = emulator$rows[own],
       residuals = emulator$y[own, , drop = FALSE] - grid_apply(emulator, stencils))
}

# Node indices (m x 4, NA where the axis ends) of the stencil of each value v
# on the sorted axis x: the nodes of v's cell and one more on each side.
axis_stencil <- function(x, v) {
  n <- length(x)
  if (n == 1L) return(matrix(1L, length(v), 1L))
  i <- findInterval(v, x, rightmost.closed = TRUE, all.inside = TRUE)
  index <- cbind(i - 1L, i, i + 1L, i + 2L)
  index[index < 1L | index > n] <- NA
  index
}

# The leave-one-out stencil of node i of an axis of n nodes: the 2 nodes on
# each side, not i; at an end of the axis the 3 nearest, so that the end is
# extrapolated by a quadratic as the interpolation's end cells are (an axis
# of one node keeps it: nothing to leave out).
axis_loo_stencil <- function(n, i) {
  if (n == 1L) return(matrix(1L, length(i), 1L))
  index <- cbind(i - 2L, i - 1L, i + 1L, i + 2L)
  index[i == 1L, 1L] <- 4L
  index[i == n, 4L] <- n - 3L
  index[index < 1L | index > n] <- NA
  index
}

# Lagrange weights at v of the stencil nodes x[index] (m x s, NA absent, its
# weight 0). At a node the factors are exactly 1 and 0, so nodes are
# reproduced exactly.
lagrange_weights <- function(x, index, v) {
  s <- ncol(index)
  weight <- matrix(0, nrow(index), s)
  for (a in seq_len(s)) {
    w <- rep(1, nrow(index))
    for (b in seq_len(s)[-a]) {
      f <- (v - x[index[, b]]) / (x[index[, a]] - x[index[, b]])
      w <- w * ifelse(is.na(index[, b]), 1, f)
    }
    weight[, a] <- ifelse(is.na(index[, a]), 0, w)
  }
  weight
}

# Tensor product of the axes' stencils (list of index and weight, m x s_j,
# full-axis node indices) applied to the stored outputs: the sparse product,
# one stencil slot (a column of the index and weight matrices) at a time, so
# memory holds m x n_out, not m x 4^p x n_out.
grid_apply <- function(emulator, stencils) {
  m <- nrow(stencils[[1]]$index)
  key <- matrix(1, m, 1L)
  weight <- matrix(1, m, 1L)
  stride <- 1
  for (j in seq_along(stencils)) {
    index <- stencils[[j]]$index
    w <- stencils[[j]]$weight
    first <- emulator$keep[[j]][1]
    index[is.na(index)] <- first  # a slot of weight 0; any stored node will do
    s <- ncol(index)
    k <- ncol(key)
    key <- key[, rep(seq_len(k), s), drop = FALSE] +
      (index[, rep(seq_len(s), each = k), drop = FALSE] - first) * stride
    weight <- weight[, rep(seq_len(k), s), drop = FALSE] * w[, rep(seq_len(s), each = k),
                                                             drop = FALSE]
    stride <- stride * length(emulator$keep[[j]])
  }
  out <- matrix(0, m, ncol(emulator$y))
  for (slot in seq_len(ncol(key))) {
    if (any(weight[, slot] != 0)) {
      out <- out + weight[, slot] * emulator$y[key[, slot], , drop = FALSE]
    }
  }
  out
}

# Scaled distance from each row of theta to its nearest grid node: the
# nearest node of a tensor grid is the nearest value on each axis.
grid_nearest_distance <- function(emulator, theta) {
  d2 <- 0
  for (j in seq_along(emulator$axes)) {
    x <- emulator$axes[[j]]
    i <- findInterval(theta[, j], x, all.inside = length(x) > 1L)
    gap <- if (length(x) == 1L) abs(theta[, j] - x) else
      pmin(abs(theta[, j] - x[i]), abs(x[i + 1L] - theta[, j]))
    d2 <- d2 + (gap / emulator$range[j])^2
  }
  sqrt(d2)
}

# Median over the stored nodes of the scaled distance to the nearest other
# node: along each axis the smaller gap to a neighbour, the least over axes.
grid_median_spacing <- function(emulator) {
  nn <- Inf
  for (j in seq_along(emulator$keep)) {
    x <- emulator$axes[[j]][emulator$keep[[j]]] / emulator$range[j]
    gap <- if (length(x) == 1L) Inf else pmin(c(Inf, diff(x)), c(diff(x), Inf))
    nn <- pmin(rep(nn, times = length(gap)), rep(gap, each = length(nn)))
  }
  stats::median(nn)
}
