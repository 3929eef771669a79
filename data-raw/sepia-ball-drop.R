# SEPIA's ball drop 1 files (examples/Ball_Drop/data of the lanl/SEPIA
# repository, BSD-3), read from a checkout or a bare git snapshot. Sourced by
# data-raw/real-data-gap.R and bench/published-discrepancy.R, so both read
# the same numbers the same way. SEPIA_DIR: where the repository is.
source("data-raw/sepia-files.R")  # sepia_dir, sepia_file()
numbers <- function(name) {
  as.matrix(read.table(text = sepia_file(file.path("examples/Ball_Drop/data", name))))
}
design <- stats::setNames(as.data.frame(numbers("sim.design")), c("radius", "C"))
h_sim <- as.vector(numbers("sim.height"))
h_field <- as.vector(numbers("field.height"))
radii <- as.vector(numbers("field.radii"))
expobs <- data.frame(radius = radii, numbers("field.dat"))

# SEPIA's posterior of C as its notebooks print it (SepiaPlot.param_stats(),
# native scale: mean, sd, 5% and 95% quantiles): the `which`-th
# "theta_native" line of examples/Ball_Drop/<notebook>.ipynb, and the
# effective sample size over theta the notebook prints ("Max effective
# sample size over thetas"), NA where it prints none. Read from the
# notebook's stored outputs, not retyped.
sepia_theta <- function(notebook, which = 1L) {
  text <- sepia_file(file.path("examples/Ball_Drop", paste0(notebook, ".ipynb")))
  hits <- regmatches(text, regexpr("theta_native( +[-0-9.e]+){4}", text))
  values <- as.numeric(strsplit(trimws(sub("theta_native", "", hits[[which]])), " +")[[1]])
  ess <- regmatches(text, regexpr("effective sample size over thetas: [0-9]+", text))
  list(mean = values[1], sd = values[2], lower = values[3], upper = values[4],
       ess = if (length(ess) > 0L) as.numeric(sub(".*: ", "", ess[[1]])) else NA_real_,
       source = paste0("examples/Ball_Drop/", notebook, ".ipynb"))
}
