// The exact posterior over (run, grid point) of R/engine.R in a few
// passes over C, without the runs x grid points temporaries of the R
// expression (each as large as C: 8 GB at 10^6 runs x 1,000 grid points):
// the posterior over runs and over grid points, the log normalising constant
// and, when asked, the joint probabilities (one matrix, written once).
//
// log p(i, g, y) - const = log pi_i + log pi_g - log|R_g| / 2
//                          - (a + n/2) log(b + C_ig / 2)
// (collapsed_log_fit() and grid_log_weight() of grid_posterior.h).
//
// The passes over C and their pruning are those of griddy::CollapsedJoint
// (grid_posterior.h), which the stream's log evidence shares (log_mass_cpp()
// below). For the joint, entries more than 800 below the largest are left
// out: they have exp() = 0 in double precision relative to it, as in R's
// exp(lj - log_norm); for the margins alone, log(N G) + 37, as for the log
// mass.
#include <RcppArmadillo.h>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>
#include "grid_posterior.h"
#include "parallel_waves.h"

namespace {

constexpr double kNegligibleJoint = 800.0;

void check_shapes(arma::uword N, arma::uword G, R_xlen_t n_run, R_xlen_t n_grid,
                  R_xlen_t n_logdet) {
  if (static_cast<arma::uword>(n_run) != N || static_cast<arma::uword>(n_logdet) != G ||
      static_cast<arma::uword>(n_grid) != G || N == 0 || G == 0) {
    Rcpp::stop("grid_posterior: C is %d x %d but there are %d run priors, %d grid priors "
               "and %d log-determinants", static_cast<int>(N), static_cast<int>(G),
               static_cast<int>(n_run), static_cast<int>(n_grid), static_cast<int>(n_logdet));
  }
}

}  // namespace

// [[Rcpp::export]]
Rcpp::List grid_posterior_cpp(const arma::mat& C, double shape_post, double rate,
                              const Rcpp::NumericVector& logdet,
                              const Rcpp::NumericVector& log_prior_run,
                              const Rcpp::NumericVector& log_prior_grid, bool joint,
                              int threads = 1) {
  const arma::uword N = C.n_rows, G = C.n_cols;
  check_shapes(N, G, log_prior_run.size(), log_prior_grid.size(), logdet.size());
  const griddy::CollapsedJoint lj(C.memptr(), N, G, shape_post, rate, logdet.begin(),
                                  log_prior_run.begin(), log_prior_grid.begin(), threads);
  const double top = lj.top();
  Rcpp::NumericVector run(N);
  double* run_sum = run.begin();
  // every entry is written by weigh(): no zero-filling pass first
  Rcpp::NumericMatrix joint_out = joint ? Rcpp::NumericMatrix(Rcpp::no_init(N, G))
                                        : Rcpp::NumericMatrix(0, 0);
  double* J = joint_out.begin();
  const std::vector<double> grid_sums = lj.weigh(
    top, joint ? kNegligibleJoint : lj.negligible_mass(),
    [&](arma::uword i, arma::uword g, double w) {
      run_sum[i] += w;
      if (joint) J[g * N + i] = w;
    });
  double total = 0.0;
  for (double v : grid_sums) total += v;
  Rcpp::NumericVector grid(grid_sums.begin(), grid_sums.end());
  for (arma::uword g = 0; g < G; ++g) grid[g] /= total;
  for (arma::uword i = 0; i < N; ++i) run_sum[i] /= total;
  if (joint) {
    griddy::parallel_waves(G, G, threads, [&](long long g, int) {
      double* j = J + g * N;
      for (arma::uword i = 0; i < N; ++i) j[i] /= total;
    });
  }
  Rcpp::List out = Rcpp::List::create(
    Rcpp::Named("run") = run, Rcpp::Named("grid") = grid,
    Rcpp::Named("log_norm") = griddy::CollapsedJoint::log_mass(top, grid_sums),
    Rcpp::Named("joint") = R_NilValue);
  if (joint) out["joint"] = joint_out;
  return out;
}

// The log mass alone, log sum_{i,g} p(i, g, y) less the evidence's constant:
// the same passes as grid_posterior_cpp() without the per-run sums (the
// stream's log evidence, after each measurement).
// [[Rcpp::export]]
double log_mass_cpp(const arma::mat& C, double shape_post, double rate,
                    const Rcpp::NumericVector& logdet, const Rcpp::NumericVector& log_prior_run,
                    const Rcpp::NumericVector& log_prior_grid, int threads = 1) {
  check_shapes(C.n_rows, C.n_cols, log_prior_run.size(), log_prior_grid.size(), logdet.size());
  return griddy::CollapsedJoint(C.memptr(), C.n_rows, C.n_cols, shape_post, rate,
                                logdet.begin(), log_prior_run.begin(), log_prior_grid.begin(),
                                threads).log_mass();
}
