# Issue 34, item 2: should gp_discrepancy()'s default length_x grid
# (0.1, 0.3, 1 on x scaled to [0, 1]) reach longer lengths? Measured on
# Brynjarsdottir and O'Hagan's (2014) simple machine (simulator theta x,
# reality theta x / (1 + x / 20), theta = 0.65, 11 settings on [0.2, 4],
# noise sd 0.01; as bench/simple-machine-knowledge.R), 10 noise seeds, for
# three length_x grids (L3 = 0.1, 0.3, 1; L4 = L3 + 3; L5 = L3 + 3, 10) and
# three discrepancies: knowledge (zero_at = flat_at = x = 0), the orthogonal
# default, plain (orthogonal = FALSE). Per fit: calibrate() (4,000
# iterations, 500 burn-in), predict(fit, newdata = x in {5, 6}, simulator=)
# and whether the 95% band for a new measurement (pred_lower, pred_upper)
# holds reality there (the true mean; a new measurement would add sd 0.01),
# its width, the posterior share of each length; theta's exact 95% interval
# (posterior_exact(), joint = FALSE) and whether it holds 0.65; the log
# evidence and the seconds of calibrate().
# Run from the package root: Rscript bench/length-grid.R
# Writes bench/results/length-grid.csv. (The gap screen and false alarms:
# bench/length-grid-gap.R.)
pkgload::load_all(".", quiet = TRUE)

x <- data.frame(x = seq(0.2, 4, length.out = 11))
truth <- 0.65
reality <- function(x) truth * x / (1 + x / 20)
theta <- data.frame(theta = seq(0.3, 1, by = 0.0025))
lib <- sim_library(theta, outer(theta$theta, x$x), x = x)
simulator <- function(theta, x) outer(theta$theta, x$x)
grids <- list(L3 = c(0.1, 0.3, 1), L4 = c(0.1, 0.3, 1, 3), L5 = c(0.1, 0.3, 1, 3, 10))
kinds <- list(
  knowledge = function(lx) gp_discrepancy(length_x = lx, zero_at = data.frame(x = 0),
                                          flat_at = data.frame(x = 0)),
  orthogonal = function(lx) gp_discrepancy(length_x = lx),
  plain = function(lx) gp_discrepancy(length_x = lx, orthogonal = FALSE))
new <- data.frame(x = c(5, 6))

one <- function(seed, grid, kind) {
  set.seed(seed)
  field <- field_data(matrix(reality(x$x) + stats::rnorm(nrow(x), sd = 0.01)), x = x)
  disc <- kinds[[kind]](grids[[grid]])
  t0 <- proc.time()[["elapsed"]]
  fit <- suppressWarnings(calibrate(lib, field, discrepancy = disc, n_iter = 4000,
                                    burn_in = 500, seed = seed))
  secs <- proc.time()[["elapsed"]] - t0
  p <- predict(fit, newdata = new, simulator = simulator, seed = seed)
  ex <- posterior_exact(lib, field, discrepancy = disc, joint = FALSE)
  cp <- cumsum(ex$run)
  iv <- theta$theta[c(which(cp >= 0.025)[1], which(cp >= 0.975)[1])]
  # the lengths' posterior shares among the draws with a discrepancy
  lx <- as.data.frame(fit)$delta_length_x
  long <- mean(lx >= 3, na.rm = TRUE)
  top1 <- mean(lx == 1, na.rm = TRUE)
  data.frame(seed = seed, grid = grid, kind = kind, x = new$x, truth = reality(new$x),
             mean = p$mean, pred_lower = p$pred_lower, pred_upper = p$pred_upper,
             covers = p$pred_lower <= reality(new$x) & reality(new$x) <= p$pred_upper,
             width = p$pred_upper - p$pred_lower,
             share_length_1 = top1, share_length_3plus = long,
             theta_lower = iv[1], theta_upper = iv[2],
             theta_covers = iv[1] <= truth && truth <= iv[2],
             log_evidence = ex$log_evidence, seconds_calibrate = secs)
}

rows <- list()
for (grid in names(grids)) for (kind in names(kinds)) for (seed in 1:10) {
  rows[[length(rows) + 1L]] <- one(seed, grid, kind)
  r <- rows[[length(rows)]]
  message(grid, " ", kind, " seed ", seed, ": covers ", paste(r$covers, collapse = "/"),
          sprintf(" (%.1f s)", r$seconds_calibrate[1]))
}
res <- do.call(rbind, rows)
dir.create("bench/results", showWarnings = FALSE)
utils::write.csv(res, "bench/results/length-grid.csv", row.names = FALSE)
summ <- do.call(rbind, lapply(split(res, list(res$kind, res$grid, res$x), drop = TRUE), function(d) {
  data.frame(kind = d$kind[1], grid = d$grid[1], x = d$x[1], covers = sum(d$covers),
             of = nrow(d), width_median = stats::median(d$width),
             share_long = mean(d$share_length_3plus), theta_covers = sum(d$theta_covers),
             theta_width_median = stats::median(d$theta_upper - d$theta_lower),
             seconds_median = stats::median(d$seconds_calibrate))
}))
print(summ[order(summ$kind, summ$x, summ$grid), ], row.names = FALSE, digits = 3)
