# Issue 36, item 1: a shorter default chain with one correlation grid point?
# There every collapsed iteration is an independent draw from the exact
# posterior, so the question is how many draws the checks and summary()
# need. On the simple machine (calibrate-overhead.R's first problem), 40
# seeds per length: the effective draws calibrate()'s checks compute (they
# ask for at least 400) and the CPU seconds of fit_diagnostics() per fit.
# Run from the package root: GRIDDY_LIB=... Rscript bench/sized-chain-draws.R
lib <- Sys.getenv("GRIDDY_LIB")
if (nzchar(lib)) library(griddy, lib.loc = lib) else library(griddy)
src <- readLines("bench/calibrate-overhead.R")
eval(parse(text = src[grep("^overhead_problems <- function", src):
                        (grep("^elapsed <- function", src) - 1L)]))
p <- overhead_problems()$simple_machine
library_ <- sim_library(p$theta, p$y, x = p$x)
field <- field_data(p$field_y, x = p$field_x)
cpu <- function(f, n = 50) {
  t <- system.time(for (i in seq_len(n)) f())
  (t[["user.self"]] + t[["sys.self"]]) / n
}
rows <- lapply(list(c(1250, 250), c(2250, 250), c(5000, 1000)), function(len) {
  fits <- lapply(1:40, function(s) {
    suppressWarnings(calibrate(library_, field, seed = s, n_iter = len[1], burn_in = len[2]))
  })
  e <- vapply(fits, function(f) f$diagnostics$effective_draws, 0)
  data.frame(n_iter = len[1], burn_in = len[2], draws = len[1] - len[2],
             effective_min = min(e), effective_q10 = unname(stats::quantile(e, 0.1)),
             effective_median = stats::median(e), below_400 = sum(e < 400),
             diagnostics_cpu_s = cpu(function() asNamespace("griddy")$fit_diagnostics(fits[[1]])),
             calibrate_cpu_s = cpu(function() {
               suppressWarnings(calibrate(library_, field, seed = 1, n_iter = len[1],
                                          burn_in = len[2]))
             }))
})
out <- do.call(rbind, rows)
print(out, digits = 4)
utils::write.csv(out, "bench/results/sized-chain-draws.csv", row.names = FALSE)
