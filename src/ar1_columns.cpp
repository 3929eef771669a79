// The AR(1) whitening of many series at once, column by column (R/engine.R,
// whiten_rows()): M holds one series per row (n_x blocks of n_t outputs),
// and w_{j+1} = (e_{j+1} - phi_j e_j) / sqrt(1 - phi_j^2) is, for one j, a
// pass over two columns of M. ar1_whiten_rows_cpp() (grid_posterior.cpp)
// gives the same values, one series at a time, through two transposes of
// the whole matrix; at a discrepancy fit's 1,296 runs x 480 outputs those
// were most of its time.
#include <Rcpp.h>
#include <cmath>

// [[Rcpp::export]]
Rcpp::NumericMatrix ar1_whiten_columns_cpp(const Rcpp::NumericMatrix& M,
                                           const Rcpp::NumericVector& phi, int n_x) {
  const int runs = M.nrow();
  const int n = M.ncol();
  if (n_x < 1 || n % n_x != 0 || (n / n_x > 0 && phi.size() != n / n_x - 1)) {
    Rcpp::stop("AR(1) transform: %d lag coefficients for %d outputs in %d series",
               static_cast<int>(phi.size()), n, n_x);
  }
  const int n_t = n / n_x;
  Rcpp::NumericMatrix W(runs, n);
  const std::size_t r = static_cast<std::size_t>(runs);
  for (int x = 0; x < n_x; ++x) {
    const double* e = M.begin() + static_cast<std::size_t>(x) * n_t * r;
    double* w = W.begin() + static_cast<std::size_t>(x) * n_t * r;
    if (n_t > 0) std::copy(e, e + r, w);
    for (int j = 0; j + 1 < n_t; ++j) {
      const double p = phi[j];
      const double inv_sd = 1.0 / std::sqrt(1.0 - p * p);
      const double* now = e + static_cast<std::size_t>(j) * r;
      const double* next = now + r;
      double* out = w + static_cast<std::size_t>(j + 1) * r;
      for (std::size_t i = 0; i < r; ++i) out[i] = (next[i] - p * now[i]) * inv_sd;
    }
  }
  return W;
}
