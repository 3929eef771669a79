# Issue 36, item 1: does every check of calibrate() decide as before? On
# calibrate-overhead.R's four problems, seeds 1-3, calibrate() with its
# defaults: the warnings given (their classes, in order), the length of
# the chain that ran, the gap screen (log Bayes factor bound, block table),
# the stored diagnostics, the resolution table and summary() (without its
# runtime text). Run once per griddy install, then compare:
#   GRIDDY_LIB=/tmp/lib-now Rscript bench/calibrate-overhead-decisions.R main
#   GRIDDY_LIB=/tmp/lib-smallcal Rscript bench/calibrate-overhead-decisions.R smallcal
#   Rscript bench/calibrate-overhead-decisions.R compare main smallcal
# writes $TMPDIR (or /tmp)/calibrate-decisions-<label>.rds, and the comparison to
# bench/results/calibrate-overhead-decisions-<label2>.csv.
args <- commandArgs(TRUE)
decisions_file <- function(label) {
  file.path(Sys.getenv("TMPDIR", "/tmp"), paste0("calibrate-decisions-", label, ".rds"))
}
if (identical(args[1], "compare")) {
  a <- readRDS(decisions_file(args[2]))
  b <- readRDS(decisions_file(args[3]))
  rows <- lapply(names(a), function(k) {
    x <- a[[k]]
    y <- b[[k]]
    s1 <- x$summary
    s2 <- y$summary
    attr(s1, "info") <- NULL
    attr(s2, "info") <- NULL
    data.frame(case = k, warnings = paste(x$warnings, collapse = " "),
               same_warnings = identical(x$warnings, y$warnings),
               same_n_iter = identical(x$n_iter, y$n_iter),
               log_bf = if (is.null(x$screen)) NA else x$screen$log_bf,
               log_bf_diff = if (is.null(x$screen)) NA else x$screen$log_bf - y$screen$log_bf,
               same_blocks = identical(x$screen$blocks, y$screen$blocks),
               diagnostics_max_rel_diff = max(abs(unlist(x$diagnostics) /
                                                    unlist(y$diagnostics) - 1), na.rm = TRUE),
               same_resolution = identical(x$resolution, y$resolution),
               summary_equal = isTRUE(all.equal(s1, s2, tolerance = 1e-12)))
  })
  out <- do.call(rbind, rows)
  print(out)
  utils::write.csv(out, file.path("bench/results", paste0("calibrate-overhead-decisions-",
                                                          args[3], ".csv")), row.names = FALSE)
  quit(save = "no")
}
label <- if (length(args) > 0L) args[1] else "after"
lib <- Sys.getenv("GRIDDY_LIB")
if (nzchar(lib)) library(griddy, lib.loc = lib) else library(griddy)
src <- readLines("bench/calibrate-overhead.R")
eval(parse(text = src[grep("^overhead_problems <- function", src):
                        (grep("^elapsed <- function", src) - 1L)]))
res <- list()
for (name in names(overhead_problems())) {
  p <- overhead_problems()[[name]]
  library_ <- griddy::sim_library(p$theta, p$y, x = p$x, t = p$t)
  field <- griddy::field_data(p$field_y, x = p$field_x, t = p$t)
  for (seed in 1:3) {
    w <- character()
    fit <- withCallingHandlers(
      do.call(griddy::calibrate, c(list(library_, field, seed = seed), p$args)),
      warning = function(c) {
        w <<- c(w, class(c)[1])
        invokeRestart("muffleWarning")
      })
    res[[paste(name, seed)]] <- list(warnings = w, n_iter = fit$control$n_iter,
                                     screen = fit$gap_screen, diagnostics = fit$diagnostics,
                                     resolution = fit$resolution, summary = summary(fit))
  }
}
saveRDS(res, decisions_file(label))
