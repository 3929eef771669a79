# Issue 34, item 1 of the study: bench/gap-signal.R's trials without a gap
# (45) and with a 5-sd gap (15) under a given default length_x grid
# (LENGTH_X, see bench/length-grid-override.R): the false alarms and the
# detections of calibrate()'s gap warning and diagnose_gap(), whose screen
# uses gp_discrepancy()'s default grid. Run from the package root:
#   LENGTH_X=0.1,0.3,1,3 LABEL=L4 Rscript bench/length-grid-gap.R
# Writes bench/results/length-grid-gap-<LABEL>.csv.
source("bench/length-grid-override.R")
args <- character(0)
length_x_override()
exprs <- parse("bench/gap-signal.R", keep.source = FALSE)
stop_at <- which(vapply(exprs, function(e) identical(deparse(e)[1], "rows <- list()"), TRUE))
for (e in exprs[seq_len(stop_at - 1L)]) {
  if (!grepl("load_all|commandArgs", paste(deparse(e), collapse = ""))) eval(e, globalenv())
}
rows <- list()
for (size in c(0, 5)) {
  for (i in seq_len(if (size == 0) 45L else 15L)) {
    rows[[length(rows) + 1L]] <- trial(size, 1000L * size + i)
  }
  message("size ", size, " done")
}
out <- do.call(rbind, rows)
out$length_x <- Sys.getenv("LENGTH_X", "default")
utils::write.csv(out, file.path("bench/results", paste0("length-grid-gap-",
                                                        Sys.getenv("LABEL", "grid"), ".csv")),
                 row.names = FALSE)
print(do.call(rbind, lapply(split(out, out$size), function(d) {
  data.frame(size_sd = d$size[1], trials = nrow(d), calibrate_warns = sum(d$warned),
             diagnose_gap_other = sum(d$dg_other), median_dg_log_bf = stats::median(d$dg_log_bf),
             seconds = stats::median(d$seconds_calibrate + d$seconds_diagnose))
})), row.names = FALSE)
