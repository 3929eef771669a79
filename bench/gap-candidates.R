# diagnose_gap() with candidates (issue 33, item 5): replicated field data
# accepted, and the held-out shrinkage withheld where the folds cannot
# identify a candidate's strength. On tests/testthat/helper-gap.R's toy
# system (a * load * sin(3t) at three loads, noise sd 0.05), seeds 1-10:
#   rep_null    3 replicates per setting, no effect; candidates quadratic, scale
#   rep_quad    3 replicates, the quadratic effect (s = 0.1) withheld
#   bump_null   one experiment, no effect; candidates bump (a peak at load 2
#               only) and quadratic
#   bump_2.5sd  one experiment, the bump at 2.5 noise sds (s = 0.125)
#   quad_all    one experiment, the quadratic (s = 0.2, every load)
# Run: Rscript bench/gap-candidates.R (from the package root).
pkgload::load_all(".", quiet = TRUE)
source("tests/testthat/helper-gap.R")
toy <- toy_gap(0)
t <- toy$t
bump_sim <- function(a, s) toy$sim(a, 0) + c(rep(0, 30), s * exp(-((t - 0.5) / 0.1)^2), rep(0, 30))
g <- expand.grid(a = lib_theta(toy$lib)$a, s = c(0, 0.1, 0.2, 0.3))
bump <- sim_library(g, t(mapply(bump_sim, g$a, g$s)), x = toy$x, t = t)
truth <- list(rep_null = function(a) toy$sim(a, 0), rep_quad = function(a) toy$sim(a, 0.1),
              bump_null = function(a) bump_sim(a, 0), `bump_2.5sd` = function(a) bump_sim(a, 0.125),
              quad_all = function(a) toy$sim(a, 0.2))
rows <- list()
for (sc in names(truth)) for (seed in 1:10) {
  n_rep <- if (startsWith(sc, "rep")) 3L else 1L
  set.seed(seed)
  y <- do.call(rbind, lapply(seq_len(n_rep), function(r) {
    matrix(truth[[sc]](1) + rnorm(90, sd = 0.05), 3, byrow = TRUE)
  }))
  field <- field_data(y, x = toy$x[rep(1:3, n_rep), , drop = FALSE], t = t)
  fit <- suppressWarnings(calibrate(toy$lib, field, n_iter = 300, burn_in = 100, seed = 1))
  cands <- if (startsWith(sc, "rep")) list(quadratic = toy$quad, scale = toy$scale) else
    list(bump = bump, quadratic = toy$quad)
  t0 <- proc.time()[["elapsed"]]
  gap <- diagnose_gap(fit, cands, seed = 1)
  sh <- gap$shrinkage
  # the figure withheld: the pooled folds as before issue 33 (set by the grid)
  f <- gap$folds
  pooled <- function(m) sqrt(sum(f$sse[f$model == m]) / sum(f$n[f$model == m]))
  rows[[length(rows) + 1L]] <- data.frame(
    scenario = sc, seed = seed, answer = gap$verdict$answer, reason = gap$verdict$reason,
    prob = gap$verdict$prob, shrink_bump = if ("bump" %in% sh$effect) sh$shrink[sh$effect == "bump"] else NA,
    shrink_bump_withheld = if ("bump" %in% sh$effect) 1 - pooled("bump") / pooled("none") else NA,
    shrink_quadratic = sh$shrink[sh$effect == "quadratic"],
    identified_quadratic = sh$identified[sh$effect == "quadratic"],
    seconds = proc.time()[["elapsed"]] - t0)
}
res <- do.call(rbind, rows)
write.csv(res, "bench/results/gap-candidates.csv", row.names = FALSE)
summ <- do.call(rbind, lapply(split(res, res$scenario), function(d) data.frame(
  scenario = d$scenario[1], trials = nrow(d),
  answers = paste(names(table(d$answer)), table(d$answer), sep = ": ", collapse = ", "),
  bump_shrink_given = sum(!is.na(d$shrink_bump)),
  bump_withheld_range = paste(format(range(round(d$shrink_bump_withheld, 2)), nsmall = 2),
                              collapse = " to "),
  quadratic_shrink_given = sum(!is.na(d$shrink_quadratic)),
  median_quadratic_shrink = round(stats::median(d$shrink_quadratic, na.rm = TRUE), 3))))
print(summ, row.names = FALSE)
