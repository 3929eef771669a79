// The grid posterior in C++: the log weights of (run, grid point) that the
// sampler draws from, and the AR(1) whitening that defines a grid point's R_t.
// Mirrors R/grid_posterior.R, which owns the same quantities in R; each
// quantity is computed in one of the two places, never both.
#ifndef GRIDDY_GRID_POSTERIOR_H
#define GRIDDY_GRID_POSTERIOR_H

#include <RcppArmadillo.h>
#include <cmath>

namespace griddy {

// Misfit term of log p(run, grid point | y) with tau integrated out:
// -(a + n/2) log(b + C/2). `shape_post` is a + n/2.
inline double collapsed_log_fit(double C, double shape_post, double rate) {
  return -shape_post * std::log(rate + 0.5 * C);
}

// Misfit term of log p(run, grid point | y, tau): -tau C / 2.
inline double given_tau_log_fit(double C, double tau) {
  return -0.5 * tau * C;
}

// Log weight of grid point g given the run, apart from the misfit term (the
// same for every run; not the log prior weight log pi_g alone, which R calls
// log_prior_grid and computes in grid_log_prior()):
// log pi_g - log|R_g| / 2.
inline double grid_log_weight(double log_prior_grid, double logdet) {
  return log_prior_grid - 0.5 * logdet;
}

// AR(1) innovations of one series e (length n_t) with lag coefficients phi
// (length n_t - 1) and inv_sd = 1 / sqrt(1 - phi^2): w_1 = e_1,
// w_{j+1} = (e_{j+1} - phi_j e_j) inv_sd_j, so that |w|^2 = e' R_t^-1 e.
// Returns |w|^2. `w` may not alias `e`.
inline double ar1_innovations(const double* e, const double* phi, const double* inv_sd,
                              arma::uword n_t, double* w) {
  w[0] = e[0];
  double sum_sq = w[0] * w[0];
  for (arma::uword j = 0; j + 1 < n_t; ++j) {
    w[j + 1] = (e[j + 1] - phi[j] * e[j]) * inv_sd[j];
    sum_sq += w[j + 1] * w[j + 1];
  }
  return sum_sq;
}

// The inverse of ar1_innovations(): a series with correlation R_t from
// innovations z: e_1 = z_1, e_{j+1} = phi_j e_j + sqrt(1 - phi_j^2) z_{j+1}.
inline void ar1_colour(const double* z, const double* phi, arma::uword n_t, double* e) {
  e[0] = z[0];
  for (arma::uword j = 0; j + 1 < n_t; ++j) {
    e[j + 1] = phi[j] * e[j] + std::sqrt(1.0 - phi[j] * phi[j]) * z[j + 1];
  }
}

}  // namespace griddy

#endif
