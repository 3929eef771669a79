// One chain of the Griddy Gibbs sampler over a precomputed table of quadratic
// forms C (runs x correlation grid points). Each iteration draws the library
// run theta, the precision tau and the correlation grid point rho.
//
// update = "thesis" (Appendix A.3): theta | tau, rho; tau | theta, rho;
//   rho | theta, tau.
// update = "collapsed": theta | rho and rho | theta with tau integrated out
//   (Gamma-normal), then tau | theta, rho. Given rho, the collapsed
//   conditional of theta does not depend on the chain's state, so its CDF
//   (one column per grid point) is computed once, before any chain runs.
#include <RcppArmadillo.h>
#include "inverse_cdf.h"

// Column g: cumulative collapsed weights pi_i (b + C_ig / 2)^-(a + n/2),
// scaled so that the largest weight is 1.
// [[Rcpp::export]]
arma::mat collapsed_cdf_cpp(const arma::mat& C, const arma::vec& log_prior_run,
                            double shape_post, double rate) {
  arma::mat cdf(C.n_rows, C.n_cols);
  arma::vec log_w(C.n_rows);
  for (arma::uword g = 0; g < C.n_cols; ++g) {
    log_w = log_prior_run - shape_post * arma::log(rate + 0.5 * C.col(g));
    griddy::cumulative_weights(log_w.memptr(), C.n_rows, cdf.colptr(g));
  }
  return cdf;
}

// [[Rcpp::export]]
Rcpp::List gibbs_chain_cpp(const arma::mat& C, const arma::mat& cdf,
                           const arma::vec& logdet, const arma::vec& log_prior_run,
                           const arma::vec& log_prior_rho, double n_obs,
                           double shape, double rate, bool collapsed,
                           int n_iter, int first_iter, int burn_in, int thin,
                           int rho_start, double tau_start) {
  const arma::uword n_runs = C.n_rows;
  const arma::uword n_grid = C.n_cols;
  const double shape_post = shape + 0.5 * n_obs;
  const bool flat_runs = arma::all(log_prior_run == log_prior_run[0]);

  int n_keep = 0;
  for (int it = first_iter; it < first_iter + n_iter; ++it) {
    if (it > burn_in && (it - burn_in) % thin == 0) ++n_keep;
  }
  Rcpp::IntegerVector run_out(n_keep), rho_out(n_keep);
  Rcpp::NumericVector tau_out(n_keep);

  std::vector<double> log_w(std::max(n_runs, n_grid)), work(std::max(n_runs, n_grid));
  arma::uword rho = static_cast<arma::uword>(rho_start);
  arma::uword run = 0;
  double tau = tau_start;
  int k = 0;

  for (int it = first_iter; it < first_iter + n_iter; ++it) {
    if ((it - first_iter) % 256 == 0) Rcpp::checkUserInterrupt();

    // theta: a library run
    if (collapsed) {
      run = griddy::draw_from_cdf(cdf.colptr(rho), n_runs);
    } else {
      const double* c = C.colptr(rho);
      for (arma::uword i = 0; i < n_runs; ++i) {
        log_w[i] = -0.5 * tau * c[i] + (flat_runs ? 0.0 : log_prior_run[i]);
      }
      run = griddy::draw_from_log_weights(log_w.data(), n_runs, work.data());
    }

    // thesis order: tau before rho
    if (!collapsed) tau = R::rgamma(shape_post, 1.0 / (rate + 0.5 * C(run, rho)));

    // rho: a correlation grid point
    if (n_grid > 1) {
      for (arma::uword g = 0; g < n_grid; ++g) {
        const double fit = collapsed ? -shape_post * std::log(rate + 0.5 * C(run, g))
                                     : -0.5 * tau * C(run, g);
        log_w[g] = log_prior_rho[g] - 0.5 * logdet[g] + fit;
      }
      rho = griddy::draw_from_log_weights(log_w.data(), n_grid, work.data());
    }

    if (collapsed) tau = R::rgamma(shape_post, 1.0 / (rate + 0.5 * C(run, rho)));

    if (it > burn_in && (it - burn_in) % thin == 0) {
      run_out[k] = static_cast<int>(run) + 1;
      rho_out[k] = static_cast<int>(rho) + 1;
      tau_out[k] = tau;
      ++k;
    }
  }
  return Rcpp::List::create(Rcpp::Named("run") = run_out,
                            Rcpp::Named("rho") = rho_out,
                            Rcpp::Named("tau") = tau_out,
                            Rcpp::Named("rho_state") = static_cast<int>(rho),
                            Rcpp::Named("tau_state") = tau);
}
