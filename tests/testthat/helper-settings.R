# A library whose one x column is named `x` (values 2, 4, 6), 5 values of t,
# and field data from k = 1.02 with noise sd 0.02.
x_named_x_library <- function() {
  t <- seq(0, 1, length.out = 5)
  k <- seq(0.5, 1.5, length.out = 21)
  sim <- function(k) as.vector(outer(t, c(2, 4, 6), function(t, x) k * x * t))
  y <- withr::with_seed(1, matrix(sim(1.02) + stats::rnorm(15, sd = 0.02), 3, byrow = TRUE))
  list(library = sim_library(data.frame(k = k), t(vapply(k, sim, numeric(15))),
                             x = data.frame(x = c(2, 4, 6)), t = t),
       field = field_data(y, x = data.frame(x = c(2, 4, 6)), t = t))
}
