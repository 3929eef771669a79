# Writes the example library of griddy_example() to inst/extdata, in the
# thesis's design / simobs / expobs layout (one design row per x setting).
# Run from the package root: Rscript data-raw/oscillator.R

# Displacement (mm) of a mass m released from rest at x0 = 10 mm, with
# stiffness k (N/m) and damping c (N s/m); underdamped over the ranges used.
oscillator <- function(k, c, m, t, x0 = 10) {
  wn <- sqrt(k / m)
  zeta <- c / (2 * sqrt(k * m))
  wd <- wn * sqrt(1 - zeta^2)
  x0 * exp(-zeta * wn * t) * (cos(wd * t) + zeta / sqrt(1 - zeta^2) * sin(wd * t))
}

t <- seq(0, 1.5, length.out = 30)
masses <- c(1, 2, 4)
grid <- expand.grid(k = seq(500, 2000, length.out = 21), c = seq(2, 20, length.out = 21))
design <- data.frame(mass = rep(masses, each = nrow(grid)),
                     k = rep(grid$k, length(masses)), c = rep(grid$c, length(masses)))
simobs <- t(mapply(function(k, c, m) oscillator(k, c, m, t), design$k, design$c, design$mass))
colnames(simobs) <- sprintf("t%02d", seq_along(t))

truth <- c(k = 1234, c = 7.7)
set.seed(20231201)
measured <- t(vapply(masses, function(m) {
  oscillator(truth[["k"]], truth[["c"]], m, t) + rnorm(length(t), sd = 1.5)
}, numeric(length(t))))
colnames(measured) <- colnames(simobs)

out <- "inst/extdata"
data.table::fwrite(design, file.path(out, "oscillator_design.csv"))
data.table::fwrite(as.data.frame(signif(simobs, 6)), file.path(out, "oscillator_simobs.csv"))
data.table::fwrite(data.frame(mass = masses, signif(measured, 6)),
                   file.path(out, "oscillator_expobs.csv"))
data.table::fwrite(as.data.frame(as.list(truth)), file.path(out, "oscillator_truth.csv"))
