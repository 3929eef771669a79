# Does a discrepancy fit give the same numbers before and after a change to
# its algebra (issue 36, item 2)? On gap-long-field.R's system (1,296 runs,
# 480 field points): calibrate(seed = 1) with an orthogonal, a
# non-orthogonal and a scaled gp_discrepancy(), and discrepancy_posterior(
# seed = 3, ndraws = 200) of each; saved, then compared with another
# griddy's saved numbers: the draws (run, grid point identical; tau), the
# misfit table C, the log Bayes factor, delta's moments and bands.
#
# From the package root, once per griddy (same session not needed):
#   EQ_SRC=installed:<lib> EQ_OUT=/tmp/eq-a.rds Rscript bench/discrepancy-equality.R
#   EQ_COMPARE=/tmp/eq-a.rds,/tmp/eq-b.rds Rscript bench/discrepancy-equality.R
compare <- Sys.getenv("EQ_COMPARE", "")
if (nzchar(compare)) {
  f <- strsplit(compare, ",")[[1]]
  a <- readRDS(f[1])
  b <- readRDS(f[2])
  band <- c("mean", "sd", "lower", "upper")
  tab <- do.call(rbind, lapply(names(a), function(k) {
    x <- a[[k]]
    y <- b[[k]]
    data.frame(case = k,
               run_grid_identical = identical(x$draws[c("run", "grid_point")],
                                              y$draws[c("run", "grid_point")]),
               tau_max_rel = max(abs(x$draws$tau - y$draws$tau) / x$draws$tau),
               C_max_rel = max(abs(x$C - y$C) / abs(x$C)),
               log_bf_diff = x$lbf - y$lbf,
               moments_max = max(abs(as.matrix(x$post[band[1:2]]) - as.matrix(y$post[band[1:2]]))),
               bands_max = max(abs(as.matrix(x$post[band[3:4]]) - as.matrix(y$post[band[3:4]]))),
               delta_draws_max = max(abs(attr(x$post, "draws") - attr(y$post, "draws"))))
  }))
  print(tab, row.names = FALSE, digits = 3)
  out <- Sys.getenv("EQ_RESULT", "")
  if (nzchar(out)) utils::write.csv(tab, out, row.names = FALSE)
  quit(save = "no")
}
src <- Sys.getenv("EQ_SRC", ".")
if (startsWith(src, "installed:")) {
  library(griddy, lib.loc = sub("installed:", "", src, fixed = TRUE))
} else {
  pkgload::load_all(src, quiet = TRUE)
}
ns <- asNamespace("griddy")
# EQ_PATCH: an R file sourced here, e.g. to give an older griddy a newer
# function (bench/README.md says which comparison used one)
if (nzchar(Sys.getenv("EQ_PATCH"))) source(Sys.getenv("EQ_PATCH"))
source("bench/helpers.R")
sys <- damped_oscillation_system(36, 160)   # gap-long-field.R's long field
out <- list()
specs <- list(orthogonal = list(rho_t = seq(0, 0.9, by = 0.1), disc = gp_discrepancy()),
              plain_kernel = list(rho_t = seq(0, 0.9, by = 0.1),
                                  disc = gp_discrepancy(orthogonal = FALSE)),
              scaled = list(rho_t = c(0, 0.5, 0.9),
                            disc = gp_discrepancy(scaled = TRUE, length_t = c(0.3, 1),
                                                  ratio = c(0, 1, 100))))
for (k in names(specs)) {
  f <- suppressWarnings(calibrate(sys$lib, sys$field, rho_t = specs[[k]]$rho_t, seed = 1,
                                  progress = FALSE, discrepancy = specs[[k]]$disc))
  out[[k]] <- list(draws = f$draws, lbf = discrepancy_evidence(f)$log_bayes_factor,
                   C = ns$misfit_parts(ns$misfit_table(sys$lib, f$y_field, f$setup, f$prior))$C,
                   post = discrepancy_posterior(f, seed = 3, ndraws = 200))
}
saveRDS(out, Sys.getenv("EQ_OUT", "eq.rds"))
