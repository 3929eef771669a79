# A ball drop simulator: the times (s) a ball of radius `radius` (m) and
# density 80 kg/m^3 takes to fall the `heights` (m) from rest, with quadratic
# air drag. theta: `drag`, the drag coefficient C_D, and `gravity` (m/s^2).
#   m dv/dt = m g - k v^2,  k = rho_air C_D pi r^2 / 2,
#   t(h) = v_T / g * acosh(exp(g h / v_T^2)),  v_T = sqrt(m g / k).
# One row of times per row of `theta` (and of `settings`, recycled).
ball_drop <- function(theta, settings, heights = c(5, 10, 20, 30, 40, 50, 60)) {
  radius <- settings$radius
  mass <- 80 * 4 / 3 * pi * radius^3
  k <- 1.2 * theta$drag * pi * radius^2 / 2
  v_t <- sqrt(mass * theta$gravity / k)
  z <- outer(theta$gravity / v_t^2, heights)
  # acosh(exp(z)), written so that it is accurate for small z
  v_t / theta$gravity * (z + log1p(sqrt(-expm1(-2 * z))))
}
