// C_ig = (y - g_i)' R_g^{-1} (y - g_i) for every library run i and correlation
// grid point g, with R_g = kron(R_x, R_t) (thesis Appendix B). The n x n matrix is
// never formed: R_t is the correlation of an AR(1)/Ornstein-Uhlenbeck process,
// whose inverse factors into a bidiagonal "innovation" transform W = L_t^{-1} E
// (grid_posterior.h), and then C = trace(R_x^{-1} W'W).
#include <RcppArmadillo.h>
#include "grid_posterior.h"

namespace {

// The shapes quad_forms_cpp() is handed must fit together: an edited library
// or a chunk of the wrong size is an R error here, never a read past a row.
void check_quad_form_inputs(const arma::mat& Y, const arma::vec& y_field,
                            const arma::cube& Rx_inv, const arma::mat& phi) {
  const arma::uword n = y_field.n_elem;
  const arma::uword n_x = Rx_inv.n_rows;
  if (n == 0 || n_x == 0 || Rx_inv.n_cols != n_x || n % n_x != 0) {
    Rcpp::stop("quad_forms: %d field values do not split into %d x settings",
               static_cast<int>(n), static_cast<int>(n_x));
  }
  if (Y.n_cols != n) {
    Rcpp::stop("quad_forms: the outputs have %d columns but the field data %d values",
               static_cast<int>(Y.n_cols), static_cast<int>(n));
  }
  if (phi.n_rows + 1 != n / n_x) {
    Rcpp::stop("quad_forms: %d AR(1) lag coefficients for %d outputs per x setting",
               static_cast<int>(phi.n_rows), static_cast<int>(n / n_x));
  }
  if (!y_field.is_finite()) Rcpp::stop("quad_forms: the field data hold NA, NaN or Inf");
}

}  // namespace

// Runs are processed in blocks of `block` rows of Y, transposed once so each
// run's outputs are contiguous (Y is column-major: a row is strided). With
// R_x not the identity, M = W'W (a matrix product, BLAS-3) is formed once per
// run and rho_t. C is written straight into R's memory (no copy on return).
// [[Rcpp::export]]
Rcpp::NumericMatrix quad_forms_cpp(const arma::mat& Y, const arma::vec& y_field,
                                   const arma::cube& Rx_inv, const arma::mat& phi) {
  check_quad_form_inputs(Y, y_field, Rx_inv, phi);
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
        double sum_sq = 0.0;
        for (arma::uword x = 0; x < n_x; ++x) {
          sum_sq += griddy::ar1_innovations(e + x * n_t, phi.colptr(gt), inv_sd.colptr(gt),
                                            n_t, W.colptr(x));
        }
        if (!all_identity) M = W.t() * W;
        for (arma::uword gx = 0; gx < G_x; ++gx) {
          C(i, gx + G_x * gt) = identity[gx] ? sum_sq : arma::accu(M % Rx_inv.slice(gx));
        }
      }
    }
  }
  // An NA, NaN or Inf output, or a squared difference that overflows, makes
  // its misfit non-finite: checked here, on C, rather than in another pass
  // over the outputs.
  if (!C.is_finite()) {
    Rcpp::stop("quad_forms: a misfit is not finite: the outputs hold NA, NaN or Inf, or "
               "their squared differences from the field data overflow");
  }
  return C_out;
}
