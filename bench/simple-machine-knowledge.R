# Issue 33, item 4: what the user knows about the gap. Brynjarsdottir and
# O'Hagan's (2014) simple machine: simulator eta(x, theta) = theta x,
# reality zeta(x) = theta x / (1 + x / 20) with theta = 0.65, 11 settings
# x = seq(0.2, 4, length = 11), noise sd 0.01 (as in the paper). The gap
# delta(x) = 0.65 x^2 / (20 + x) is zero and flat at x = 0.
#
# For each of 10 noise seeds, theta's exact posterior (posterior_exact(),
# run probabilities over a library of theta on seq(0.3, 1, by = 0.0025),
# flat prior) under:
#   knowledge  gp_discrepancy(zero_at = data.frame(x = 0), flat_at = data.frame(x = 0))
#              (orthogonal = NULL -> FALSE with knowledge)
#   orth_knowledge  the same knowledge with orthogonal = TRUE asked for
#   orthogonal gp_discrepancy() (the default: orthogonal, the best-fitting theta)
#   plain      gp_discrepancy(orthogonal = FALSE) (Kennedy-O'Hagan GaSP)
#   none       no discrepancy
#   wrong      gp_discrepancy(zero_at = data.frame(x = c(1, 4))): delta(1) = 0.031 and
#              delta(4) = 0.43 (3 and 43 noise sds); no theta makes both 0
#   wrong_one  gp_discrepancy(zero_at = data.frame(x = 2)): delta(2) = 0.12 (12 noise
#              sds), but theta = 0.59 makes it 0, so the data cannot refute it
# and the 95% equal-tailed interval of theta, its width, whether it holds
# 0.65, and the log evidence; for knowledge and orthogonal also calibrate()'s
# interval from summary() (default sampler settings; rows *_calibrate, no
# evidence). A resolution check reruns seed 1 with theta on
# a grid four times finer (by = 0.000625). Sensitivity rows (step 0.00125):
# noise sd 0.05 on the 11 settings, and 20 settings seq(0.2, 4, by = 0.2) at
# sd 0.01, knowledge and the default only.
# Run from the package root: Rscript bench/simple-machine-knowledge.R
# (loads the source tree with pkgload). Writes
# bench/results/simple-machine-knowledge.csv.

pkgload::load_all(".", quiet = TRUE)

x <- data.frame(x = seq(0.2, 4, length.out = 11))
truth <- 0.65
reality <- truth * x$x / (1 + x$x / 20)
noise_sd <- 0.01

library_at <- function(step) {
  theta <- data.frame(theta = seq(0.3, 1, by = step))
  sim_library(theta, outer(theta$theta, x$x), x = x)
}

fits <- list(
  knowledge = gp_discrepancy(zero_at = data.frame(x = 0), flat_at = data.frame(x = 0)),
  orth_knowledge = gp_discrepancy(zero_at = data.frame(x = 0), flat_at = data.frame(x = 0),
                                  orthogonal = TRUE),
  orthogonal = gp_discrepancy(),
  plain = gp_discrepancy(orthogonal = FALSE),
  none = NULL,
  wrong = gp_discrepancy(zero_at = data.frame(x = c(1, 4))),
  wrong_one = gp_discrepancy(zero_at = data.frame(x = 2))
)

interval <- function(theta, p, level = 0.95) {
  cp <- cumsum(p) / sum(p)
  a <- (1 - level) / 2
  c(theta[which(cp >= a)[1]], theta[which(cp >= 1 - a)[1]], sum(theta * p) / sum(p))
}

one <- function(seed, step = 0.0025) {
  lib <- library_at(step)
  theta <- lib_theta(lib)$theta
  set.seed(seed)
  field <- field_data(matrix(reality + stats::rnorm(nrow(x), sd = noise_sd)), x = x)
  exact <- do.call(rbind, lapply(names(fits), function(nm) {
    t0 <- proc.time()[["elapsed"]]
    ex <- posterior_exact(lib, field, discrepancy = fits[[nm]], joint = FALSE)
    iv <- interval(theta, ex$run)
    data.frame(seed = seed, step = step, fit = nm, lower = iv[1], upper = iv[2],
               mean = iv[3], width = iv[2] - iv[1],
               covers = iv[1] <= truth && truth <= iv[2],
               log_evidence = ex$log_evidence,
               seconds = proc.time()[["elapsed"]] - t0)
  }))
  if (step != 0.0025) return(exact)
  # the documented route: calibrate() (default sampler settings) and summary()
  sampled <- do.call(rbind, lapply(c("knowledge", "orthogonal"), function(nm) {
    t0 <- proc.time()[["elapsed"]]
    fit <- suppressWarnings(calibrate(lib, field, discrepancy = fits[[nm]], seed = seed))
    s <- as.data.frame(unclass(summary(fit))[c("parameter", "mean", "lower", "upper")])
    s <- s[s$parameter == "theta", ]
    data.frame(seed = seed, step = step, fit = paste0(nm, "_calibrate"), lower = s$lower,
               upper = s$upper, mean = s$mean, width = s$upper - s$lower,
               covers = s$lower <= truth && truth <= s$upper, log_evidence = NA_real_,
               seconds = proc.time()[["elapsed"]] - t0)
  }))
  rbind(exact, sampled)
}

res <- do.call(rbind, lapply(1:10, one))
res <- rbind(res, one(1, step = 0.000625))
res$noise_sd <- noise_sd
res$n_x <- nrow(x)
# sensitivity (exact posteriors only, knowledge and the default): noisier
# data, and 20 settings x = 0.2, 0.4, ..., 4
fits <- fits[c("knowledge", "orthogonal")]
noise_sd <- 0.05
noisy <- do.call(rbind, lapply(1:10, one, step = 0.00125))
noisy$noise_sd <- noise_sd
noisy$n_x <- nrow(x)
noise_sd <- 0.01
x <- data.frame(x = seq(0.2, 4, by = 0.2))
reality <- truth * x$x / (1 + x$x / 20)
dense <- do.call(rbind, lapply(1:10, one, step = 0.00125))
dense$noise_sd <- noise_sd
dense$n_x <- nrow(x)
res <- rbind(res, noisy, dense)
dir.create("bench/results", showWarnings = FALSE)
utils::write.csv(res, "bench/results/simple-machine-knowledge.csv", row.names = FALSE)

main <- res[res$step == 0.0025 & res$noise_sd == 0.01 & res$n_x == 11, ]
ref <- main[main$fit == "orthogonal", c("seed", "log_evidence")]
main$dlogZ_vs_orthogonal <- main$log_evidence - ref$log_evidence[match(main$seed, ref$seed)]
# knowledge against the same discrepancy without it (plain: orthogonal = FALSE)
ref <- main[main$fit == "plain", c("seed", "log_evidence")]
main$dlogZ_vs_plain <- main$log_evidence - ref$log_evidence[match(main$seed, ref$seed)]
summ <- do.call(rbind, lapply(split(main, main$fit), function(d) {
  data.frame(fit = d$fit[1], covers = sum(d$covers), of = nrow(d),
             width_min = min(d$width), width_median = stats::median(d$width),
             width_max = max(d$width), mean_min = min(d$mean), mean_max = max(d$mean),
             log_evidence_median = stats::median(d$log_evidence),
             dlogZ_vs_orthogonal_min = min(d$dlogZ_vs_orthogonal),
             dlogZ_vs_orthogonal_max = max(d$dlogZ_vs_orthogonal),
             dlogZ_vs_plain_min = min(d$dlogZ_vs_plain),
             dlogZ_vs_plain_max = max(d$dlogZ_vs_plain))
}))
print(summ[order(match(summ$fit, c(names(fits), paste0(names(fits), "_calibrate")))), ],
      row.names = FALSE, digits = 3)
cat("\nsensitivity: noise sd 0.05 (11 settings), and 20 settings (sd 0.01):\n")
sens <- res[res$step == 0.00125, ]
print(stats::aggregate(cbind(covers, width) ~ fit + noise_sd + n_x, sens,
                       function(v) c(sum = sum(v), min = min(v), max = max(v))), digits = 3)
cat("\nresolution check, seed 1 (step 0.0025 against 0.000625):\n")
print(res[res$seed == 1 & res$step %in% c(0.0025, 0.000625), c("fit", "step", "lower", "upper", "width", "log_evidence")],
      row.names = FALSE, digits = 4)
