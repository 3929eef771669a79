// R entry points to the AR(1) transforms of grid_posterior.h, applied to rows
// of a matrix in library order (blocks of n_t outputs by x setting), for the
// R code that whitens residuals (diagnose_gap) or draws correlated noise
// (predict).
#include <RcppArmadillo.h>
#include "grid_posterior.h"

namespace {

void check_rows(const arma::mat& M, const arma::vec& phi, int n_x) {
  if (n_x < 1 || M.n_cols % n_x != 0) {
    Rcpp::stop("AR(1) transform: %d columns do not split into %d x settings",
               static_cast<int>(M.n_cols), n_x);
  }
  const arma::uword n_t = M.n_cols / n_x;
  if (n_t > 0 && phi.n_elem + 1 != n_t) {
    Rcpp::stop("AR(1) transform: %d lag coefficients for series of length %d",
               static_cast<int>(phi.n_elem), static_cast<int>(n_t));
  }
}

}  // namespace

// [[Rcpp::export]]
arma::mat ar1_whiten_rows_cpp(const arma::mat& M, const arma::vec& phi, int n_x) {
  check_rows(M, phi, n_x);
  const arma::uword n_t = M.n_cols / n_x;
  if (n_t < 2) return M;
  const arma::vec inv_sd = 1.0 / arma::sqrt(1.0 - arma::square(phi));
  const arma::mat Mt = M.t();  // each run's outputs contiguous
  arma::mat Wt(Mt.n_rows, Mt.n_cols);
  for (arma::uword i = 0; i < Mt.n_cols; ++i) {
    for (int x = 0; x < n_x; ++x) {
      griddy::ar1_innovations(Mt.colptr(i) + x * n_t, phi.memptr(), inv_sd.memptr(), n_t,
                              Wt.colptr(i) + x * n_t);
    }
  }
  return Wt.t();
}

// [[Rcpp::export]]
arma::mat ar1_colour_rows_cpp(const arma::mat& Z, const arma::vec& phi, int n_x) {
  check_rows(Z, phi, n_x);
  const arma::uword n_t = Z.n_cols / n_x;
  if (n_t < 2) return Z;
  const arma::mat Zt = Z.t();
  arma::mat Et(Zt.n_rows, Zt.n_cols);
  for (arma::uword i = 0; i < Zt.n_cols; ++i) {
    for (int x = 0; x < n_x; ++x) {
      griddy::ar1_colour(Zt.colptr(i) + x * n_t, phi.memptr(), n_t, Et.colptr(i) + x * n_t);
    }
  }
  return Et.t();
}
