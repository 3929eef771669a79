# Issue 34, item 1: predict() at new x settings without a simulator, from an
# emulated library's emulator, beside the same prediction through the
# simulator; and predict() of a stream. Toy: y = a x exp(-b t) + 0.1 x,
# N_T = 10 t in [0, 1]; a joint design of N_DESIGN (default 150) runs, a
# Latin hypercube over (x in [0.2, 4], a in [0.5, 1.5], b in [0.5, 2]);
# an emulated library of 10^4 runs at 5 settings; field data from a = 1.02,
# b = 1.23, noise sd 0.05, no gap. Timed (elapsed s, one call each, on a
# shared machine): calibrate(), predict() at the library's settings, at 3
# new settings inside the design (x = 1, 2.5, 3.5) by the emulator and by the
# simulator; recorded: the emulator's mean error against the simulator's
# prediction, the band widths of both, and whether the truth is in the
# predictive band. Then a stream over a 10^4-run sim_library of the same
# toy: predict() at the library's settings and at the new ones.
# Run from the package root: Rscript bench/predict-emulated.R; writes
# bench/results/predict-emulated.csv.
pkgload::load_all(".", quiet = TRUE)
n_design <- as.integer(Sys.getenv("N_DESIGN", "150"))
n_t <- 10L
t <- seq(0, 1, length.out = n_t)
x <- data.frame(x = seq(0.2, 4, length.out = 5))
toy <- function(a, b, xs) unlist(lapply(xs, function(v) a * v * exp(-b * t) + 0.1 * v))
simulator <- function(theta, x) {
  matrix(t(mapply(function(a, b) toy(a, b, x$x), theta$a, theta$b)), nrow(theta))
}
set.seed(34)
u <- vapply(1:3, function(j) (sample.int(n_design) - runif(n_design)) / n_design,
            numeric(n_design))
design <- data.frame(x = 0.2 + 3.8 * u[, 1], a = 0.5 + u[, 2], b = 0.5 + 1.5 * u[, 3])
y <- t(mapply(function(v, a, b) a * v * exp(-b * t) + 0.1 * v, design$x, design$a, design$b))
elapsed <- function(expr) system.time(expr)[["elapsed"]]
t_lib <- elapsed(lib <- emulated_library(design[c("a", "b")], y, x = design["x"], t = t,
                                         settings = x, n_runs = 10000, seed = 1))
truth <- toy(1.02, 1.23, x$x)
field <- field_data(matrix(truth + rnorm(length(truth), sd = 0.05), nrow(x), byrow = TRUE),
                    x = x, t = t)
t_fit <- elapsed(fit <- suppressWarnings(calibrate(lib, field, n_iter = 5000, burn_in = 1000,
                                                   seed = 1)))
new <- data.frame(x = c(1, 2.5, 3.5))
t_at_lib <- elapsed(predict(fit, seed = 1))
t_em <- elapsed(pe <- predict(fit, newdata = new, seed = 1))
t_sim <- elapsed(ps <- predict(fit, newdata = new, seed = 1, simulator = simulator))
real_new <- toy(1.02, 1.23, new$x)
grid <- expand.grid(a = seq(0.5, 1.5, length.out = 100), b = seq(0.5, 2, length.out = 100))
sim_lib <- sim_library(grid, simulator(grid, x), x = x, t = t)
t_stream <- elapsed(s <- update(griddy_stream(sim_lib), y = field))
t_s_lib <- elapsed(predict(s, seed = 1))
t_s_new <- elapsed(pn <- predict(s, newdata = new, seed = 1, simulator = simulator))
out <- data.frame(
  date = format(Sys.time(), "%Y-%m-%d %H:%M"), n_design = n_design, n_runs = 10000,
  emulator_loo_rms = lib$loo_rms, t_emulated_library = t_lib, t_calibrate = t_fit,
  t_predict_library = t_at_lib, t_predict_new_emulator = t_em,
  t_predict_new_simulator = t_sim,
  emulator_vs_simulator_mean_max = max(abs(pe$mean - ps$mean)),
  band_width_emulator = mean(pe$upper - pe$lower),
  band_width_simulator = mean(ps$upper - ps$lower),
  truth_in_pred_band_emulator = mean(pe$pred_lower <= real_new & real_new <= pe$pred_upper),
  truth_in_pred_band_simulator = mean(ps$pred_lower <= real_new & real_new <= ps$pred_upper),
  t_stream_update = t_stream, t_stream_predict_library = t_s_lib,
  t_stream_predict_new = t_s_new,
  truth_in_pred_band_stream = mean(pn$pred_lower <= real_new & real_new <= pn$pred_upper))
print(t(out))
file <- "bench/results/predict-emulated.csv"
utils::write.table(out, file, sep = ",", row.names = FALSE, append = file.exists(file),
                   col.names = !file.exists(file))
