# SEPIA's ball drop 1 files (examples/Ball_Drop/data of the lanl/SEPIA
# repository, BSD-3), read from a checkout or a bare git snapshot. Sourced by
# data-raw/real-data-gap.R and bench/published-discrepancy.R, so both read
# the same numbers the same way. SEPIA_DIR: where the repository is.
sepia_dir <- Sys.getenv("SEPIA_DIR", "/work/.mirror/lanl+SEPIA/repo")
sepia_file <- function(path) {
  if (file.exists(file.path(sepia_dir, path))) return(readLines(file.path(sepia_dir, path)))
  system2("git", c("--git-dir", shQuote(sepia_dir), "show", paste0("HEAD:", path)),
          stdout = TRUE)
}
numbers <- function(name) {
  as.matrix(read.table(text = sepia_file(file.path("examples/Ball_Drop/data", name))))
}
design <- stats::setNames(as.data.frame(numbers("sim.design")), c("radius", "C"))
h_sim <- as.vector(numbers("sim.height"))
h_field <- as.vector(numbers("field.height"))
radii <- as.vector(numbers("field.radii"))
expobs <- data.frame(radius = radii, numbers("field.dat"))
