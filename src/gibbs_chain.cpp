// One chain of the Griddy Gibbs sampler over a precomputed table of quadratic
// forms C (runs x correlation grid points). Each iteration draws the library
// run theta, the precision tau and the correlation grid point rho.
//
// update = "thesis" (Appendix A.3): theta | tau, rho; tau | theta, rho;
//   rho | theta, tau.
// update = "collapsed": theta | rho and rho | theta with tau integrated out
//   (Gamma-normal), then tau | theta, rho. Given rho, the collapsed
//   conditional of theta does not depend on the chain's state, so its CDF
//   (one per grid point) is computed once, before any chain runs.
//
// Both theta draws run over the runs sorted by C_ig, whose weights fall
// monotonically with C_ig, and keep only the head of that list: the runs
// left out hold less than `tol` of the total weight (see log_budget() in
// inverse_cdf.h), so a draw costs the head's length, not N.
#include <RcppArmadillo.h>
#include <numeric>
#include <vector>
#include "inverse_cdf.h"

namespace {

// Runs of column g in increasing order of C (ties in run order), 0-based.
void sort_column(const double* c, arma::uword n, int* order) {
  std::iota(order, order + n, 0);
  std::stable_sort(order, order + n, [c](int a, int b) { return c[a] < c[b]; });
}

}  // namespace

// Every column's run order (0-based), for the thesis update, whose weights
// exp(-tau C_ig / 2) change with tau: the head is found per draw.
// [[Rcpp::export]]
Rcpp::IntegerMatrix run_order_cpp(const arma::mat& C) {
  Rcpp::IntegerMatrix order(C.n_rows, C.n_cols);
  for (arma::uword g = 0; g < C.n_cols; ++g) {
    Rcpp::checkUserInterrupt();
    sort_column(C.colptr(g), C.n_rows, &order[g * C.n_rows]);
  }
  return order;
}

// The collapsed theta | rho draw of every grid point g: the head of the runs
// sorted by C_ig (those whose weight pi_i (b + C_ig / 2)^-(a + n/2) can
// exceed tol / N of the first run's) and their cumulative weights, scaled so
// the largest weight is 1. Ragged columns stored end to end: column g is
// positions start[g] to start[g + 1] - 1 of `run` (0-based) and `cdf`.
// [[Rcpp::export]]
Rcpp::List collapsed_heads_cpp(const arma::mat& C, const arma::vec& log_prior_run,
                               double shape_post, double rate, double tol) {
  const arma::uword n = C.n_rows;
  const double lp_max = log_prior_run.max();
  std::vector<int> start(C.n_cols + 1, 0), runs;
  std::vector<double> cdf, log_w;
  std::vector<int> head;
  for (arma::uword g = 0; g < C.n_cols; ++g) {
    Rcpp::checkUserInterrupt();
    const double* c = C.colptr(g);
    const arma::uword first = std::min_element(c, c + n) - c;
    const double budget = griddy::log_budget(n, tol, lp_max, log_prior_run[first]);
    // (b + C/2) / (b + C_min/2) > exp(budget / shape_post) leaves the head
    const double cut = 2.0 * ((rate + 0.5 * c[first]) * std::exp(budget / shape_post) - rate);
    head.clear();
    for (arma::uword i = 0; i < n; ++i) {
      if (!(c[i] > cut)) head.push_back(static_cast<int>(i));
    }
    std::stable_sort(head.begin(), head.end(), [c](int a, int b) { return c[a] < c[b]; });
    const arma::uword k = head.size();
    log_w.resize(k);
    for (arma::uword j = 0; j < k; ++j) {
      log_w[j] = log_prior_run[head[j]] - shape_post * std::log(rate + 0.5 * c[head[j]]);
    }
    const std::size_t at = cdf.size();
    cdf.resize(at + k);
    griddy::cumulative_weights(log_w.data(), k, cdf.data() + at);
    runs.insert(runs.end(), head.begin(), head.end());
    start[g + 1] = static_cast<int>(runs.size());
  }
  return Rcpp::List::create(Rcpp::Named("start") = Rcpp::wrap(start),
                            Rcpp::Named("run") = Rcpp::wrap(runs),
                            Rcpp::Named("cdf") = Rcpp::wrap(cdf));
}

// [[Rcpp::export]]
Rcpp::List gibbs_chain_cpp(const arma::mat& C, const Rcpp::IntegerMatrix& order,
                           const Rcpp::List& heads, const arma::vec& logdet,
                           const arma::vec& log_prior_run, const arma::vec& log_prior_rho,
                           double n_obs, double shape, double rate, bool collapsed,
                           double tol, int n_iter, int first_iter, int burn_in, int thin,
                           int rho_start, double tau_start) {
  const arma::uword n_runs = C.n_rows;
  const arma::uword n_grid = C.n_cols;
  const double shape_post = shape + 0.5 * n_obs;
  const bool flat_runs = arma::all(log_prior_run == log_prior_run[0]);
  const double lp_max = log_prior_run.max();

  int n_keep = 0;
  for (int it = first_iter; it < first_iter + n_iter; ++it) {
    if (it > burn_in && (it - burn_in) % thin == 0) ++n_keep;
  }
  Rcpp::IntegerVector run_out(n_keep), rho_out(n_keep);
  Rcpp::NumericVector tau_out(n_keep);

  // collapsed: the precomputed heads; thesis: the sorted orders and, per grid
  // point, the log-weight budget of the truncation
  Rcpp::IntegerVector head_start, head_run;
  Rcpp::NumericVector head_cdf;
  std::vector<double> budget(n_grid);
  if (collapsed) {
    head_start = heads["start"];
    head_run = heads["run"];
    head_cdf = heads["cdf"];
  } else {
    for (arma::uword g = 0; g < n_grid; ++g) {
      budget[g] = griddy::log_budget(n_runs, tol, lp_max, log_prior_run[order(0, g)]);
    }
  }

  std::vector<double> log_w(std::max(n_runs, n_grid)), work(std::max(n_runs, n_grid));
  arma::uword rho = static_cast<arma::uword>(rho_start);
  arma::uword run = 0;
  double tau = tau_start;
  double head_total = 0.0;
  int k = 0;

  for (int it = first_iter; it < first_iter + n_iter; ++it) {
    if ((it - first_iter) % 256 == 0) Rcpp::checkUserInterrupt();

    // theta: a library run
    if (collapsed) {
      const int from = head_start[rho];
      const arma::uword len = head_start[rho + 1] - from;
      run = head_run[from + griddy::draw_from_cdf(&head_cdf[from], len)];
      head_total += len;
    } else {
      const double* c = C.colptr(rho);
      const int* o = &order[rho * n_runs];
      const double c_min = c[o[0]];
      const arma::uword len = griddy::head_length(c, o, n_runs,
                                                  c_min + 2.0 * budget[rho] / tau);
      for (arma::uword j = 0; j < len; ++j) {
        log_w[j] = -0.5 * tau * (c[o[j]] - c_min) + (flat_runs ? 0.0 : log_prior_run[o[j]]);
      }
      run = o[griddy::draw_from_log_weights(log_w.data(), len, work.data())];
      head_total += len;
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
                            Rcpp::Named("tau_state") = tau,
                            Rcpp::Named("head_total") = head_total);
}
