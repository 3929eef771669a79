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

// [[Rcpp::export]]
arma::mat quad_forms_cpp(const arma::mat& Y, const arma::vec& y_field,
                         const arma::cube& Rx_inv, const arma::mat& phi) {
  const arma::uword n_runs = Y.n_rows;
  const arma::uword n_x = Rx_inv.n_rows;
  const arma::uword n_t = y_field.n_elem / n_x;
  const arma::uword G_x = Rx_inv.n_slices;
  const arma::uword G_t = phi.n_cols;
  arma::mat inv_sd = 1.0 / arma::sqrt(1.0 - arma::square(phi));

  // Slices equal to the identity need only the sum of squared innovations.
  std::vector<bool> identity(G_x);
  for (arma::uword gx = 0; gx < G_x; ++gx) {
    identity[gx] = arma::approx_equal(Rx_inv.slice(gx), arma::eye(n_x, n_x),
                                      "absdiff", 0.0);
  }

  arma::mat C(n_runs, G_x * G_t);
  arma::mat E(n_t, n_x), W(n_t, n_x), M(n_x, n_x);
  for (arma::uword i = 0; i < n_runs; ++i) {
    if (i % 1024 == 0) Rcpp::checkUserInterrupt();
    for (arma::uword k = 0; k < y_field.n_elem; ++k) E[k] = y_field[k] - Y(i, k);
    for (arma::uword gt = 0; gt < G_t; ++gt) {
      if (n_t > 1) {
        griddy::ar1_innovations(E, phi.col(gt), inv_sd.col(gt), W);
      } else {
        W = E;
      }
      const double sum_sq = arma::accu(arma::square(W));
      bool have_M = false;
      for (arma::uword gx = 0; gx < G_x; ++gx) {
        double c;
        if (identity[gx]) {
          c = sum_sq;
        } else {
          if (!have_M) {
            M = W.t() * W;
            have_M = true;
          }
          c = arma::accu(M % Rx_inv.slice(gx));
        }
        C(i, gx + G_x * gt) = c;
      }
    }
  }
  return C;
}
