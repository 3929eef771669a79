// The exact posterior over (run, grid point) of R/grid_posterior.R in a few
// passes over C, without the runs x grid points temporaries of the R
// expression (each as large as C: 8 GB at 10^6 runs x 1,000 grid points):
// the posterior over runs and over grid points, the log normalising constant
// and, when asked, the joint probabilities (one matrix, written once).
//
// log p(i, g, y) - const = log pi_i + log pi_g - log|R_g| / 2
//                          - (a + n/2) log(b + C_ig / 2)
// (collapsed_log_fit() and grid_log_weight() of grid_posterior.h).
//
// The log joint falls with C_ig, so its bound
// log pi_max + log pi_g - log|R_g|/2 - (a + n/2) log(b + C_ig/2) is a
// threshold on C. The first pass finds, per grid point, the smallest C, an
// entry whose value is known; `best`, the largest of these, is the largest
// log joint when the runs' prior is flat. The second pass looks for a larger
// one only among entries whose bound exceeds `best`, and the third takes
// logs only of the entries whose bound lies less than `negligible` below it.
// For the joint, that is 800: the others have exp() = 0 in double precision
// relative to the largest, as in R's exp(lj - log_norm). For the margins
// alone, it is log(N G) + 37: the entries left out weigh less than
// exp(-37) = 8.5e-17 of the largest together, below the rounding of the
// total, and in a concentrated posterior most entries are.
//
// Passes over runs go in blocks of a fixed size on `threads` threads
// (parallel_waves.h), with each block's sums kept apart and added in block
// order, so the result does not depend on the number of threads.
#include <RcppArmadillo.h>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>
#include "grid_posterior.h"
#include "parallel_waves.h"

namespace {

constexpr arma::uword kBlockRuns = 4096;
constexpr double kNegligibleJoint = 800.0;
constexpr double kNegligibleMargins = 37.0;  // plus log(N G)

}  // namespace

// [[Rcpp::export]]
Rcpp::List grid_posterior_cpp(const arma::mat& C, double shape_post, double rate,
                              const Rcpp::NumericVector& logdet,
                              const Rcpp::NumericVector& log_prior_run,
                              const Rcpp::NumericVector& log_prior_grid, bool joint,
                              int threads = 1) {
  const arma::uword N = C.n_rows, G = C.n_cols;
  if (static_cast<arma::uword>(log_prior_run.size()) != N ||
      static_cast<arma::uword>(logdet.size()) != G ||
      static_cast<arma::uword>(log_prior_grid.size()) != G || N == 0 || G == 0) {
    Rcpp::stop("grid_posterior: C is %d x %d but there are %d run priors, %d grid priors "
               "and %d log-determinants", static_cast<int>(N), static_cast<int>(G),
               static_cast<int>(log_prior_run.size()), static_cast<int>(log_prior_grid.size()),
               static_cast<int>(logdet.size()));
  }
  const double* lpr = log_prior_run.begin();
  const double lp_max = *std::max_element(lpr, lpr + N);
  std::vector<double> grid_term(G);
  for (arma::uword g = 0; g < G; ++g) {
    grid_term[g] = griddy::grid_log_weight(log_prior_grid[g], logdet[g]);
  }
  auto log_joint = [&](arma::uword i, arma::uword g, double c) {
    return grid_term[g] + lpr[i] + griddy::collapsed_log_fit(c, shape_post, rate);
  };

  // pass 1: per grid point, the entry with the smallest C, whose value bounds
  // the largest from below
  std::vector<double> known(G);
  griddy::parallel_waves(G, G, threads, [&](long long g, int) {
    const double* c = C.colptr(g);
    const arma::uword i = std::min_element(c, c + N) - c;
    known[g] = log_joint(i, g, c[i]);
  });
  const double best = *std::max_element(known.begin(), known.end());
  // the C below which an entry's bound exceeds `level` (all C when level is -Inf)
  auto c_below = [&](arma::uword g, double level) {
    if (!std::isfinite(level)) return std::numeric_limits<double>::infinity();
    return 2.0 * (std::exp((grid_term[g] + lp_max - level) / shape_post) - rate);
  };
  const double negligible = joint ? kNegligibleJoint :
    kNegligibleMargins + std::log(static_cast<double>(N) * G);
  std::vector<double> may_beat(G), cut(G);
  for (arma::uword g = 0; g < G; ++g) {
    may_beat[g] = c_below(g, best);
    cut[g] = c_below(g, best - negligible);
  }

  // pass 2: the largest log joint (any value near it would do: it only keeps
  // exp() in range)
  const long long n_blocks = (N + kBlockRuns - 1) / kBlockRuns;
  std::vector<double> block_max(n_blocks, -std::numeric_limits<double>::infinity());
  const long long wave = std::max<long long>(1, 1e8 / (static_cast<double>(kBlockRuns) * G));
  auto rows_of = [&](long long b, arma::uword& from, arma::uword& to) {
    from = static_cast<arma::uword>(b) * kBlockRuns;
    to = std::min<arma::uword>(N, from + kBlockRuns);
  };
  griddy::parallel_waves(n_blocks, wave, threads, [&](long long b, int) {
    arma::uword from, to;
    rows_of(b, from, to);
    double top = best;
    for (arma::uword g = 0; g < G; ++g) {
      const double* c = C.colptr(g);
      for (arma::uword i = from; i < to; ++i) {
        if (c[i] < may_beat[g]) top = std::max(top, log_joint(i, g, c[i]));
      }
    }
    block_max[b] = top;
  });
  const double top = *std::max_element(block_max.begin(), block_max.end());

  // pass 3: weights relative to the largest, summed per run and, per block,
  // per grid point; the joint written as it goes
  Rcpp::NumericVector run(N);
  double* run_sum = run.begin();
  // every entry is written below: no zero-filling pass first
  Rcpp::NumericMatrix joint_out = joint ? Rcpp::NumericMatrix(Rcpp::no_init(N, G))
                                        : Rcpp::NumericMatrix(0, 0);
  double* J = joint_out.begin();
  std::vector<double> block_grid(static_cast<std::size_t>(n_blocks) * G, 0.0);
  griddy::parallel_waves(n_blocks, wave, threads, [&](long long b, int) {
    arma::uword from, to;
    rows_of(b, from, to);
    double* grid_sum = &block_grid[static_cast<std::size_t>(b) * G];
    for (arma::uword g = 0; g < G; ++g) {
      const double* c = C.colptr(g);
      double* j = joint ? J + g * N : nullptr;
      double sum = 0.0;
      for (arma::uword i = from; i < to; ++i) {
        const double w = c[i] > cut[g] ? 0.0 : std::exp(log_joint(i, g, c[i]) - top);
        run_sum[i] += w;
        sum += w;
        if (j) j[i] = w;
      }
      grid_sum[g] = sum;
    }
  });
  Rcpp::NumericVector grid(G);
  for (long long b = 0; b < n_blocks; ++b) {
    for (arma::uword g = 0; g < G; ++g) grid[g] += block_grid[static_cast<std::size_t>(b) * G + g];
  }
  double total = 0.0;
  for (arma::uword g = 0; g < G; ++g) total += grid[g];
  for (arma::uword g = 0; g < G; ++g) grid[g] /= total;
  for (arma::uword i = 0; i < N; ++i) run_sum[i] /= total;
  if (joint) {
    griddy::parallel_waves(G, G, threads, [&](long long g, int) {
      double* j = J + g * N;
      for (arma::uword i = 0; i < N; ++i) j[i] /= total;
    });
  }
  Rcpp::List out = Rcpp::List::create(Rcpp::Named("run") = run, Rcpp::Named("grid") = grid,
                                      Rcpp::Named("log_norm") = top + std::log(total),
                                      Rcpp::Named("joint") = R_NilValue);
  if (joint) out["joint"] = joint_out;
  return out;
}
