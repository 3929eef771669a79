#!/bin/sh
# Builds griddy as a processor without x86 SIMD gets it (the plain C++
# kernels of src/tiled_product.cpp alone, -DGRIDDY_PORTABLE_ONLY) into a
# temporary library and runs the tests of the products and of calibrate()
# there. The package's own tests force the plain kernels at run time
# (`portable = TRUE`), but only this build compiles and runs the code with the
# x86 dispatch left out, as on ARM. Run from the package root:
#   sh tools/check-portable-build.sh
set -e
lib=$(mktemp -d)
trap 'rm -rf "$lib"' EXIT
# a user Makevars adds the flag (the package's Makevars sets PKG_CPPFLAGS)
echo 'CPPFLAGS += -DGRIDDY_PORTABLE_ONLY' >"$lib/Makevars"
R_MAKEVARS_USER="$lib/Makevars" R CMD INSTALL --preclean -l "$lib" . >"$lib/install.log" 2>&1 ||
  { cat "$lib/install.log"; exit 1; }
R_LIBS="$lib" Rscript -e '
  library(griddy)
  stopifnot(!griddy:::quad_forms_avx2_cpp())  # the x86 kernels are not compiled in
  cat("griddy built without the x86 kernels; AVX2 in use:", griddy:::quad_forms_avx2_cpp(), "\n")
  for (f in c("grid_posterior", "calibrate", "posterior_exact", "calibration_memory")) {
    res <- as.data.frame(testthat::test_file(file.path("tests/testthat", paste0("test-", f, ".R")),
                                             package = "griddy", load_package = "installed",
                                             reporter = "summary"))
    if (any(res$failed > 0) || any(res$error)) stop("tests failed in test-", f, ".R")
  }'
