# Issue 34, item 2: the worked example of vignette("prediction").
# Brynjarsdottir and O'Hagan's (2014) simple machine: simulator theta x,
# reality theta x / (1 + x / 20), theta = 0.65, 11 settings on [0.2, 4],
# noise sd 0.01, a library of theta on seq(0.3, 1, by = 0.0025). For noise
# seeds 1 to 10, calibrate() (4,000 iterations, 500 burn-in) with the
# knowledge that the gap is zero and flat at x = 0 (zero_at = flat_at =
# data.frame(x = 0)), with the orthogonal default gp_discrepancy(), with
# orthogonal = FALSE, and without a discrepancy; then predict(fit, newdata =
# x on seq(0.2, 6, by = 0.1), simulator = ) (the library's settings through
# today's path, the others through the simulator) and theta's 95% interval
# from summary(). Run from the package root (~1 min):
#   Rscript data-raw/prediction-simple-machine.R
# Writes inst/extdata/prediction_simple_machine.csv.gz.
pkgload::load_all(".", quiet = TRUE)

x <- data.frame(x = seq(0.2, 4, length.out = 11))
reality <- function(x) 0.65 * x / (1 + x / 20)
theta <- data.frame(theta = seq(0.3, 1, by = 0.0025))
lib <- sim_library(theta, outer(theta$theta, x$x), x = x)
simulator <- function(theta, x) outer(theta$theta, x$x)
arms <- list(
  knowledge = gp_discrepancy(zero_at = data.frame(x = 0), flat_at = data.frame(x = 0)),
  orthogonal = gp_discrepancy(),
  plain = gp_discrepancy(orthogonal = FALSE),
  none = NULL)
new <- data.frame(x = sort(unique(round(c(x$x, seq(0.2, 6, by = 0.1)), 10))))

rows <- list()
for (seed in 1:10) {
  set.seed(seed)
  field <- field_data(matrix(reality(x$x) + stats::rnorm(nrow(x), sd = 0.01)), x = x)
  for (arm in names(arms)) {
    fit <- suppressWarnings(calibrate(lib, field, discrepancy = arms[[arm]], n_iter = 4000,
                                      burn_in = 500, seed = seed))
    p <- predict(fit, newdata = new, simulator = simulator, seed = seed)
    s <- as.data.frame(unclass(summary(fit))[c("parameter", "lower", "upper")])
    s <- s[s$parameter == "theta", ]
    rows[[length(rows) + 1L]] <- data.frame(
      seed = seed, arm = arm, x = p$x, in_library = !is.na(p$setting),
      truth = reality(p$x), observed = p$observed, mean = p$mean, lower = p$lower,
      upper = p$upper, pred_lower = p$pred_lower, pred_upper = p$pred_upper,
      theta_lower = s$lower, theta_upper = s$upper)
  }
  message("seed ", seed, " done")
}
out <- do.call(rbind, rows)
num <- vapply(out, is.double, TRUE)
out[num] <- lapply(out[num], signif, digits = 5)
con <- gzfile("inst/extdata/prediction_simple_machine.csv.gz", "w")
utils::write.csv(out, con, row.names = FALSE)
close(con)
at <- out[out$x %in% c(5, 6), ]
print(stats::aggregate(cbind(covers = pred_lower <= truth & truth <= pred_upper,
                             width = pred_upper - pred_lower) ~ arm + x, at, mean),
      digits = 3)
