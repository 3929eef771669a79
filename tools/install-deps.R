# Installs from CRAN, skipping what is already installed, every package griddy needs to build,
# install, build its vignettes and run its tests (tools/run-tests.R): DESCRIPTION's Imports,
# LinkingTo and Suggests, plus pkgload and pkgbuild (testthat::test_local() loads the source tree
# with them). Usage, from the package root:
#   Rscript tools/install-deps.R          # everything but the optional packages below
#   Rscript tools/install-deps.R --all    # also the optional packages
# Optional (their tests skip without them, no vignette needs them):
#   RobustGaSP, RobustCalibration  the KOH baseline, koh_calibrate(); compiling them and their
#                                  dependencies (RcppEigen, nloptr) from source takes several minutes
#   hdf5r                          on-disk libraries in HDF5; compiling it needs the system HDF5
#                                  library (libhdf5-dev on Debian/Ubuntu)
# Failing to install an optional package is reported, not an error.
optional <- c("RobustGaSP", "RobustCalibration", "hdf5r")
all <- "--all" %in% commandArgs(TRUE)

fields <- read.dcf("DESCRIPTION", fields = c("Imports", "LinkingTo", "Suggests"))
pkgs <- unlist(strsplit(fields[!is.na(fields)], ","))
pkgs <- trimws(sub("\\(.*", "", pkgs))
base <- rownames(installed.packages(priority = "base"))
pkgs <- setdiff(unique(c(pkgs[nzchar(pkgs)], "pkgload", "pkgbuild")), c(base, "R"))
needed <- setdiff(pkgs, optional)
wanted <- if (all) pkgs else needed

# R's configured CRAN mirror; where none is set, the first of R's own list of
# mirrors (read from R's installation, no network)
if (is.na(getOption("repos")["CRAN"]) || getOption("repos")["CRAN"] == "@CRAN@") {
  utils::chooseCRANmirror(graphics = FALSE, ind = 1, local.only = TRUE)
}
repos <- getOption("repos")
have <- function(p) vapply(p, function(q) nzchar(system.file(package = q)), logical(1))
missing <- wanted[!have(wanted)]

# testthat needs pkgload, which needs fs; fs compiled from source links to the system libuv or,
# with USE_BUNDLED_LIBUV=1, builds the copy it ships, which takes cmake.
source_install <- .Platform$OS.type == "unix" && getOption("pkgType") == "source"
if (length(missing) && source_install && !have("fs") && !nzchar(Sys.getenv("USE_BUNDLED_LIBUV"))) {
  libuv <- nzchar(Sys.which("pkg-config")) &&
    system2("pkg-config", c("--exists", "libuv"), stdout = FALSE, stderr = FALSE) == 0
  if (!libuv && nzchar(Sys.which("cmake"))) {
    message("No system libuv: fs (for testthat) will build its bundled copy with cmake")
    Sys.setenv(USE_BUNDLED_LIBUV = "1")
  } else if (!libuv) {
    stop("testthat needs the fs package, which needs the libuv library (libuv1-dev on ",
         "Debian/Ubuntu, libuv-devel on Fedora) or cmake to build its own copy; ",
         "install one of them and run this again", call. = FALSE)
  }
}

if (length(missing)) {
  message("Installing from CRAN: ", paste(missing, collapse = ", "))
  ncpus <- max(1L, min(4L, parallel::detectCores(logical = FALSE), na.rm = TRUE))
  install.packages(missing, repos = repos, Ncpus = ncpus)
}

# An installed package can fail to load when a dependency CRAN brought in is
# newer than the one it was built against: Debian's knitr 1.42 with CRAN's
# xfun 0.62, which litedown pulls in, stops at "object 'attr' is not exported
# by 'namespace:xfun'". Reinstall from CRAN whatever does not load, checked
# in a fresh R each time (a failed load leaves the session half-loaded), and
# check again, since fixing one can fix the packages that import it.
fails_to_load <- function(p) {
  if (!length(p)) return(character())
  script <- tempfile(fileext = ".R")
  on.exit(unlink(script))
  writeLines(c("p <- commandArgs(TRUE)",
               "ok <- vapply(p, function(q) isTRUE(suppressWarnings(suppressMessages(",
               "  requireNamespace(q, quietly = TRUE)))), logical(1))",
               "cat(p[!ok], sep = '\\n')"), script)
  # the child searches this session's libraries (a user library included)
  out <- system2(file.path(R.home("bin"), "Rscript"),
                 c("--no-save", "--no-restore", "--no-init-file", script, p),
                 stdout = TRUE, stderr = FALSE,
                 env = paste0("R_LIBS=", paste(.libPaths(), collapse = .Platform$path.sep)))
  intersect(trimws(out), p)
}
for (attempt in 1:2) {
  broken <- fails_to_load(wanted[have(wanted)])
  if (!length(broken)) break
  message("Installed but not loading, reinstalling from CRAN: ", paste(broken, collapse = ", "))
  install.packages(broken, repos = repos, lib = .libPaths()[1])
}

still <- wanted[!have(wanted)]
if (length(setdiff(still, optional)))
  stop("could not install: ", paste(setdiff(still, optional), collapse = ", "), call. = FALSE)
if (length(still))
  message("Optional packages not installed (their tests will be skipped): ",
          paste(still, collapse = ", "))
if (!all)
  message("Optional packages (KOH baseline, HDF5 libraries) not requested; ",
          "`Rscript tools/install-deps.R --all` adds ", paste(optional, collapse = ", "))
