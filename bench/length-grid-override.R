# Shared by bench/length-grid-study.R and bench/length-grid-gap.R: load the
# source tree and make gp_discrepancy()'s default length_x grid the one in
# the environment variable LENGTH_X (comma-separated; unset: the package's
# own default), in the namespace (where calibrate()'s gap screen and
# diagnose_gap() call it) and for the script's own calls. Then evaluate the
# script `path` without its own pkgload::load_all() line.
pkgload::load_all(".", quiet = TRUE)
length_x_override <- function() {
  lx <- Sys.getenv("LENGTH_X")
  if (!nzchar(lx)) return(invisible(NULL))
  f <- get("gp_discrepancy", asNamespace("griddy"))
  formals(f)$length_x <- as.numeric(strsplit(lx, ",")[[1]])
  utils::assignInNamespace("gp_discrepancy", f, "griddy")
  assign("gp_discrepancy", f, envir = globalenv())
  message("gp_discrepancy() default length_x: ", lx)
}
run_without_load_all <- function(path, args = character(0)) {
  exprs <- parse(path, keep.source = FALSE)
  keep <- !vapply(exprs, function(e) grepl("load_all", paste(deparse(e), collapse = "")), TRUE)
  env <- globalenv()
  assign("commandArgs", function(trailingOnly = FALSE) args, envir = env)
  for (e in exprs[keep]) eval(e, env)
}
