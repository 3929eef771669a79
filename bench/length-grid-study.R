# Issue 34, item 1 of the study: data-raw/prediction-study.R under a given
# default length_x grid (LENGTH_X, see bench/length-grid-override.R), its
# table written to bench/results/prediction-study-<LABEL>.csv instead of
# inst/extdata. Run from the package root:
#   LENGTH_X=0.1,0.3,1 LABEL=L3 N_TRIALS=15 Rscript bench/length-grid-study.R
source("bench/length-grid-override.R")
length_x_override()
shipped <- "inst/extdata/prediction_study.csv.gz"
before <- if (file.exists(shipped)) readBin(shipped, "raw", file.size(shipped))
run_without_load_all("data-raw/prediction-study.R")
file.copy(shipped, file.path("bench/results", paste0("prediction-study-",
                                                     Sys.getenv("LABEL", "grid"), ".csv.gz")),
          overwrite = TRUE)
if (!is.null(before)) writeBin(before, shipped) else unlink(shipped)
