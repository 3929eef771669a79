# SEPIA's posteriors (data-raw/sepia-reference.py's draws) summarised per
# case and parameter: mean, sd, the 2.5/5/95/97.5% quantiles and the
# draws' effective sample size (posterior::ess_bulk), into
# inst/extdata/sepia_reference_summary.csv, which vignette("real-data-gap")
# reads beside the draws' own file. Run from the package root after the
# Python driver:
#   SEPIA_SRC=/tmp/sepia /usr/bin/python3 data-raw/sepia-reference.py ball_drop_1 \
#     ball_drop_1_noD ball_drop_2
#   Rscript data-raw/sepia-reference.R
dir <- "inst/extdata"
files <- list.files(dir, pattern = "^sepia_.*\\.csv\\.gz$", full.names = TRUE)
summaries <- lapply(files, function(f) {
  draws <- utils::read.csv(f)
  case <- sub("^sepia_(.*)\\.csv\\.gz$", "\\1", basename(f))
  pars <- setdiff(names(draws), "logPost")
  do.call(rbind, lapply(pars, function(p) {
    v <- draws[[p]]
    q <- stats::quantile(v, c(0.025, 0.05, 0.95, 0.975), names = FALSE)
    data.frame(case = case, parameter = p, mean = mean(v), sd = stats::sd(v),
               q025 = q[1], q05 = q[2], q95 = q[3], q975 = q[4], draws = length(v),
               ess = posterior::ess_bulk(v))
  }))
})
out <- do.call(rbind, summaries)
utils::write.csv(out, file.path(dir, "sepia_reference_summary.csv"), row.names = FALSE)
print(out, digits = 4)
