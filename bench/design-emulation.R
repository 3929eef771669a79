# Emulating a library from a design (emulated_library(), issue 13):
#
# A. Accuracy: the emulator griddy uses, one RobustGaSP::ppgasp() with the
#    outputs as its vector output, against a principal-component basis (as
#    GPMSA and SEPIA: the outputs' leading components over t, one
#    RobustGaSP::rgasp() per component weight), on held-out runs of
#    joint (x, theta) Latin-hypercube designs of a smooth toy and the
#    projectile, and on complete theta designs of the piston stand-in.
# B. Speed: a 10^5-run library from 343 piston runs (3 parameters, 54
#    outputs, the thesis's ch. 3 scale), sequential and on two workers.
#
# Run from the package root: Rscript bench/design-emulation.R (a few
# minutes). Writes bench/results/design-emulation.csv; the tables are in
# bench/results/design-emulation.md.

pkgload::load_all(".", quiet = TRUE)
source("bench/helpers.R")
suppressMessages(library(RobustGaSP))

lhs <- function(n, lower, upper) {
  u <- vapply(seq_along(lower), function(j) (sample.int(n) - runif(n)) / n, numeric(n))
  sweep(sweep(matrix(u, n), 2, upper - lower, "*"), 2, lower, "+")
}

# Joint problems: f(x, theta) -> n_t outputs, x one column.
smooth <- list(name = "smooth", x = c(0, 1), lower = c(1, 0.1), upper = c(3, 0.5),
               names = c("k", "c"), settings = c(0.2, 0.5, 0.8),
               f = function(x, th) {
                 t <- seq(0, 2, length.out = 10)
                 exp(-outer(th[, 2], t)) * sin(outer(th[, 1], t) + x)
               })
projectile <- list(name = "projectile", x = c(15, 75), lower = c(10, 0.05),
                   upper = c(40, 1), names = c("v0", "drag"), settings = c(30, 45, 60),
                   f = function(x, th) {
                     t <- seq(0.1, 4, length.out = 20)
                     v_up <- th[, 1] * sin(x * pi / 180)
                     k <- th[, 2]
                     (v_up + 9.81 / k) / k * (1 - exp(-outer(k, t))) - outer(9.81 / k, t)
                   })

truth_at <- function(prob, th) {
  do.call(cbind, lapply(prob$settings, function(x) prob$f(rep(x, nrow(th)), th)))
}

rel_rmse <- function(pred, truth) {
  s <- apply(truth, 2, sd)
  ok <- s > 0
  sqrt(mean((sqrt(colMeans((pred - truth)^2))[ok] / s[ok])^2))
}

# The principal-component route, on the same scaled inputs.
pc_emulator <- function(z, Y, energy = 0.999, max_k = 10) {
  mu <- colMeans(Y)
  sv <- svd(sweep(Y, 2, mu))
  k <- min(which(cumsum(sv$d^2) / sum(sv$d^2) >= energy)[1], max_k)
  basis <- sv$v[, seq_len(k), drop = FALSE]
  w <- sweep(Y, 2, mu) %*% basis
  fits <- lapply(seq_len(k), function(j) {
    out <- NULL
    utils::capture.output(out <- rgasp(design = z, response = w[, j], nugget.est = TRUE))
    out
  })
  list(mu = mu, basis = basis, fits = fits)
}
pc_predict <- function(em, z) {
  w <- vapply(em$fits, function(f) predict(f, z)$mean, numeric(nrow(z)))
  sweep(matrix(w, nrow(z)) %*% t(em$basis), 2, em$mu, "+")
}

rows <- list()
held_out <- 200L
set.seed(13)
for (prob in list(smooth, projectile)) {
  for (n in c(40L, 150L)) {
    x <- runif(n, prob$x[1], prob$x[2])
    th <- lhs(n, prob$lower, prob$upper)
    colnames(th) <- prob$names
    y <- t(vapply(seq_len(n), function(i) prob$f(x[i], th[i, , drop = FALSE]),
                  numeric(ncol(prob$f(1, th[1, , drop = FALSE])))))
    th_new <- lhs(held_out, prob$lower, prob$upper)
    colnames(th_new) <- prob$names
    truth <- truth_at(prob, th_new)
    lib <- NULL
    t_gp <- time_it(lib <- emulated_library(th, y, x = data.frame(x = x),
                                            settings = data.frame(x = prob$settings),
                                            n_runs = 2, seed = 1))
    t_gp_pred <- time_it(pred <- design_gp_predict(lib$emulator, th_new)$mean)
    # the PC route over (x, theta) -> n_t outputs
    gp <- lib$emulator
    z <- gp_scale(gp, cbind(x, th))
    pc <- NULL
    t_pc <- time_it(pc <- pc_emulator(z, y))
    t_pc_pred <- time_it(pred_pc <- do.call(cbind, lapply(prob$settings, function(s) {
      pc_predict(pc, gp_scale(gp, cbind(s, th_new)))
    })))
    rows[[length(rows) + 1L]] <- data.frame(
      problem = prob$name, design = "joint LHS (x, theta)", runs = n,
      method = c("ppgasp (vector output)", "PC basis + rgasp"),
      held_out_rel_rmse = c(rel_rmse(pred, truth), rel_rmse(pred_pc, truth)),
      loo_rel_rmse = c(sqrt(mean(gp$loo^2)) / sd(y), NA),
      fit_s = c(t_gp, t_pc), predict_s = c(t_gp_pred, t_pc_pred),
      components = c(NA, length(pc$fits)))
  }
}

# The piston stand-in: complete designs (every theta at all 54 settings).
rng <- piston_htc_ranges()
piston_f <- function(th) unname(piston_model(th, condition = c("full", "part")))
for (n in c(100L, 343L)) {
  th <- lhs(n, rng$min, rng$max)
  colnames(th) <- rng$parameter
  y <- piston_f(th)
  th_new <- lhs(held_out, rng$min, rng$max)
  colnames(th_new) <- rng$parameter
  truth <- piston_f(th_new)
  lib <- NULL
  t_gp <- time_it(lib <- emulated_library(th, y, n_runs = 2, seed = 1))
  t_gp_pred <- time_it(pred <- design_gp_predict(lib$emulator, th_new)$mean)
  z <- gp_scale(lib$emulator, th)
  pc <- NULL
  t_pc <- time_it(pc <- pc_emulator(z, y))
  t_pc_pred <- time_it(pred_pc <- pc_predict(pc, gp_scale(lib$emulator, th_new)))
  rows[[length(rows) + 1L]] <- data.frame(
    problem = "piston", design = "complete theta LHS", runs = n,
    method = c("ppgasp (vector output)", "PC basis + rgasp"),
    held_out_rel_rmse = c(rel_rmse(pred, truth), rel_rmse(pred_pc, truth)),
    loo_rel_rmse = c(sqrt(mean(lib$emulator$loo^2)) / sd(y), NA),
    fit_s = c(t_gp, t_pc), predict_s = c(t_gp_pred, t_pc_pred),
    components = c(NA, length(pc$fits)))
}
accuracy <- do.call(rbind, rows)
print(accuracy, digits = 3)

# ---- B. speed: 10^5 runs from 343 ----------------------------------------------
set.seed(3)
th <- lhs(343L, rng$min, rng$max)
colnames(th) <- rng$parameter
y <- piston_f(th)
speed <- list()
t_seq <- time_it(lib <- emulated_library(th, y, n_runs = 1e5, seed = 1))
speed[[1]] <- data.frame(plan = "sequential", seconds = t_seq)
future::plan(future::multisession, workers = 2)
invisible(future.apply::future_lapply(1:2, function(i) i))  # workers started apart
t_par <- time_it(lib2 <- emulated_library(th, y, n_runs = 1e5, seed = 1))
future::plan(future::sequential)
speed[[2]] <- data.frame(plan = "multisession, 2 workers", seconds = t_par)
speed <- do.call(rbind, speed)
speed$identical <- c(NA, isTRUE(all.equal(lib$y, lib2$y)))
print(speed)
g <- lib$emulator
fit_only <- time_it(design_gp(list(theta = th, x = matrix(0, 343, 0), y = y),
                              matrix(0, 1, 0)))
cat("fit + LOO alone:", fit_only, "s\n")

out <- rbind(
  cbind(part = "accuracy", accuracy, plan = NA, seconds = NA),
  cbind(part = "speed", problem = "piston", design = "complete theta LHS", runs = 343,
        method = "ppgasp (vector output)", held_out_rel_rmse = NA, loo_rel_rmse = NA,
        fit_s = fit_only, predict_s = NA, components = NA, speed[, c("plan", "seconds")]))
out$machine <- machine_note()
utils::write.csv(out, "bench/results/design-emulation.csv", row.names = FALSE)
