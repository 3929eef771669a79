# SEPIA's Al-5083 flyer-plate files (examples/Al_5083/data of the lanl/SEPIA
# repository, BSD-3; data LA-UR-18-20151, Walters et al. 2018, J. Appl.
# Phys. 124, 205105), read from a checkout or a bare git snapshot at
# SEPIA_DIR, the way SEPIA's Al_5083_calibration.py reads them:
#   Al.trial5.design.txt      1,000 runs of 11 strength parameters (a
#                             header of names, then one row per run);
#   features_cdf10{4,5,6}S.csv the runs' features for shots 104, 105, 106
#                             (10 columns: 5 pairs of a time and a feature);
#   features_cdf_obs10{4,5,6}S.csv the measured features, one row each.
# SEPIA keeps 4 features per shot (columns 4, 6, 8, 10, 1-based), multiplies
# the simulated ones by 10,000 (the measured ones are already in those
# units), and gives a known observation covariance Sigy = diag(0.01 * y_obs):
# a variance (SepiaData's Sigy is the observation covariance), so the
# observation sd of feature j is sqrt(0.01 * y_obs[j]). Sourced by
# data-raw/al5083.R.
sepia_dir <- Sys.getenv("SEPIA_DIR", "/work/.mirror/lanl+SEPIA/repo")
sepia_file <- function(path) {
  if (file.exists(file.path(sepia_dir, path))) return(readLines(file.path(sepia_dir, path)))
  system2("git", c("--git-dir", shQuote(sepia_dir), "show", paste0("HEAD:", path)),
          stdout = TRUE)
}
al_file <- function(name) sepia_file(file.path("examples/Al_5083/data", name))
al_csv <- function(name) as.matrix(utils::read.csv(text = al_file(name)))
al_shots <- c("104S", "105S", "106S")
al_features <- c(4L, 6L, 8L, 10L)
al_design <- utils::read.table(text = al_file("Al.trial5.design.txt"), header = TRUE)
al_sim <- do.call(cbind, lapply(al_shots, function(s) {
  1e4 * al_csv(paste0("features_cdf", s, ".csv"))[, al_features]
}))
al_obs <- unlist(lapply(al_shots, function(s) {
  al_csv(paste0("features_cdf_obs", s, ".csv"))[1, al_features]
}))
al_output_names <- paste0("s", rep(substr(al_shots, 1, 3), each = 4), "_f", al_features)
dimnames(al_sim) <- list(NULL, al_output_names)
names(al_obs) <- al_output_names
al_obs_sd <- sqrt(0.01 * al_obs)
