// C_ig = (y - g_i)' R_g^{-1} (y - g_i) for every library run i and correlation
// grid point g, with R_g = kron(R_x, R_t) (thesis Appendix B). The n x n matrix is
// never formed: R_t is the correlation of an AR(1)/Ornstein-Uhlenbeck process,
// whose inverse factors into a bidiagonal "innovation" transform W = L_t^{-1} E,
// and then C = trace(R_x^{-1} W'W).
#include <RcppArmadillo.h>
#include "quadratic_forms.h"

namespace griddy {

// Innovations of the residual blocks E (n_t x n_x) under AR(1) correlation
// with lag coefficients phi (length n_t - 1): w_1 = e_1,
// w_{j+1} = (e_{j+1} - phi_j e_j) / sqrt(1 - phi_j^2).
void ar1_innovations(const arma::mat& E, const arma::vec& phi,
                     const arma::vec& inv_sd, arma::mat& W) {
  W.row(0) = E.row(0);
  for (arma::uword j = 0; j + 1 < E.n_rows; ++j) {
    W.row(j + 1) = (E.row(j + 1) - phi[j] * E.row(j)) * inv_sd[j];
  }
}

}  // namespace griddy

// Runs are processed in blocks of `block` rows of Y, transposed once so each
// run's outputs are contiguous (Y is column-major: a row is strided), and the
// innovations are plain loops over raw memory. With R_x not the identity,
// M = W'W (a matrix product, BLAS-3) is formed once per run and rho_t.
// C is written straight into R's memory (no copy on return).
// [[Rcpp::export]]
Rcpp::NumericMatrix quad_forms_cpp(const arma::mat& Y, const arma::vec& y_field,
                         const arma::cube& Rx_inv, const arma::mat& phi) {
  const arma::uword n_runs = Y.n_rows;
  const arma::uword n = y_field.n_elem;
  const arma::uword n_x = Rx_inv.n_rows;
  const arma::uword n_t = n / n_x;
  const arma::uword G_x = Rx_inv.n_slices;
  const arma::uword G_t = phi.n_cols;
  const arma::mat inv_sd = 1.0 / arma::sqrt(1.0 - arma::square(phi));

  // Slices equal to the identity need only the sum of squared innovations.
  std::vector<bool> identity(G_x);
  bool all_identity = true;
  for (arma::uword gx = 0; gx < G_x; ++gx) {
    identity[gx] = arma::approx_equal(Rx_inv.slice(gx), arma::eye(n_x, n_x),
                                      "absdiff", 0.0);
    all_identity = all_identity && identity[gx];
  }

  Rcpp::NumericMatrix C_out(n_runs, G_x * G_t);
  arma::mat C(C_out.begin(), n_runs, G_x * G_t, false, true);
  const arma::uword block = 256;
  arma::mat Yt;
  arma::mat E(n_t, n_x), W(n_t, n_x), M(n_x, n_x);
  for (arma::uword i0 = 0; i0 < n_runs; i0 += block) {
    Rcpp::checkUserInterrupt();
    const arma::uword i1 = std::min(n_runs, i0 + block) - 1;
    Yt = Y.rows(i0, i1).t();
    for (arma::uword b = 0; b < Yt.n_cols; ++b) {
      const arma::uword i = i0 + b;
      const double* yi = Yt.colptr(b);
      double* e = E.memptr();
      for (arma::uword k = 0; k < n; ++k) e[k] = y_field[k] - yi[k];
      for (arma::uword gt = 0; gt < G_t; ++gt) {
        const double* ph = phi.colptr(gt);
        const double* sd = inv_sd.colptr(gt);
        double* w = W.memptr();
        double sum_sq = 0.0;
        for (arma::uword x = 0; x < n_x; ++x) {
          const double* ex = e + x * n_t;
          double* wx = w + x * n_t;
          wx[0] = ex[0];
          sum_sq += wx[0] * wx[0];
          for (arma::uword j = 0; j + 1 < n_t; ++j) {
            wx[j + 1] = (ex[j + 1] - ph[j] * ex[j]) * sd[j];
            sum_sq += wx[j + 1] * wx[j + 1];
          }
        }
        if (!all_identity) M = W.t() * W;
        for (arma::uword gx = 0; gx < G_x; ++gx) {
          C(i, gx + G_x * gt) = identity[gx] ? sum_sq : arma::accu(M % Rx_inv.slice(gx));
        }
      }
    }
  }
  return C_out;
}
