// The reshapes of the discrepancy's Kronecker products (R/discrepancy-engine.R,
// kron_product() and kron_coordinates()): a matrix whose rows are runs
// within blocks, regrouped so that a product over one axis is one matrix
// product. In R each took array() + aperm() + matrix(), three copies of
// every run's residuals per grid point; here one.
#include <Rcpp.h>
#include <algorithm>

// X, read as a matrix of runs a rows whatever its dimensions, holds runs-long
// blocks: block (i, j) is rows i runs + 1..(i + 1) runs of column col0 + j
// (0-based i < a, j < b). Returns Y (runs b x a) with block (j, i) = block
// (i, j) of X: the array [runs, a, b] (from column col0) permuted to
// [runs, b, a], as aperm() would, value for value.
// [[Rcpp::export]]
Rcpp::NumericMatrix block_transpose_cpp(const Rcpp::NumericVector& X, int runs, int a, int b,
                                        int col0) {
  if (runs < 0 || a < 0 || b < 0 || col0 < 0 ||
      static_cast<double>(runs) * a * (col0 + b) > static_cast<double>(X.size())) {
    Rcpp::stop("block_transpose: the blocks do not fit the matrix.");
  }
  Rcpp::NumericMatrix Y(runs * b, a);
  const std::size_t n = static_cast<std::size_t>(runs);
  const std::size_t rows_x = n * static_cast<std::size_t>(a);
  const std::size_t rows_y = static_cast<std::size_t>(Y.nrow());
  const double* x = X.begin() + static_cast<std::size_t>(col0) * rows_x;
  double* y = Y.begin();
  for (int j = 0; j < b; ++j) {
    for (int i = 0; i < a; ++i) {
      const double* from = x + static_cast<std::size_t>(j) * rows_x + i * n;
      std::copy(from, from + n, y + static_cast<std::size_t>(i) * rows_y + j * n);
    }
  }
  return Y;
}
