# Issue 36, item 1: the gap screen's parts and the diagnostics of a small
# fit, in CPU milliseconds per call (40 calls; steadier than elapsed time
# on a shared machine), beside posterior_exact(): the screen whole, its log
# evidence with the discrepancy (screen_log_mass(), or before it
# screen_problem() and grid_posterior()), its leave-block-out checks
# (screen_blocks()) and fit_diagnostics(). Run once per install:
#   GRIDDY_LIB=/tmp/lib-now Rscript bench/calibrate-overhead-parts.R main
#   GRIDDY_LIB=/tmp/lib-smallcal Rscript bench/calibrate-overhead-parts.R smallcal
# appends to bench/results/calibrate-overhead-parts.csv.
args <- commandArgs(TRUE)
label <- if (length(args) > 0L) args[1] else "after"
lib <- Sys.getenv("GRIDDY_LIB")
if (nzchar(lib)) library(griddy, lib.loc = lib) else library(griddy)
G <- asNamespace("griddy")
src <- readLines("bench/calibrate-overhead.R")
eval(parse(text = src[grep("^overhead_problems <- function", src):
                        (grep("^elapsed <- function", src) - 1L)]))
cpu_ms <- function(f, n = 40) {
  f()
  t <- system.time(for (i in seq_len(n)) f())
  (t[["user.self"]] + t[["sys.self"]]) / n * 1000
}
rows <- lapply(c("simple_machine", "three_par_rho"), function(name) {
  p <- overhead_problems()[[name]]
  library_ <- sim_library(p$theta, p$y, x = p$x, t = p$t)
  field <- field_data(p$field_y, x = p$field_x, t = p$t)
  fit <- suppressWarnings(do.call(calibrate, c(list(library_, field, seed = 1), p$args)))
  runs <- G$screen_runs(fit$exact$run)
  g <- which.max(fit$exact$grid$prob)
  mass <- if (!is.null(G$screen_log_mass)) {
    function() G$screen_log_mass(fit, runs, g)
  } else {
    function() G$grid_posterior(suppressWarnings(G$screen_problem(fit, runs, g)), joint = FALSE)
  }
  data.frame(code = label, problem = name,
             exact_ms = cpu_ms(function() do.call(posterior_exact, c(list(library_, field), p$args))),
             calibrate_ms = cpu_ms(function() {
               suppressWarnings(do.call(calibrate, c(list(library_, field, seed = 1), p$args)))
             }),
             screen_ms = cpu_ms(function() G$gap_screen(fit)),
             screen_log_mass_ms = cpu_ms(mass),
             screen_blocks_ms = cpu_ms(function() G$screen_blocks(fit, runs)),
             diagnostics_ms = cpu_ms(function() G$fit_diagnostics(fit)),
             resolution_ms = cpu_ms(function() {
               G$resolution_table(fit$exact$run, G$lib_theta(fit$library))
             }))
})
out <- do.call(rbind, rows)
print(out, digits = 3)
file <- "bench/results/calibrate-overhead-parts.csv"
utils::write.csv(rbind(if (file.exists(file)) utils::read.csv(file), out), file,
                 row.names = FALSE)
