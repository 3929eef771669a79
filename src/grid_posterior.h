// The grid posterior in C++: the log weights of (run, grid point) that the
// sampler draws from, and the AR(1) whitening that defines a grid point's R_t.
// Mirrors R/engine.R, which owns the same quantities in R; each
// quantity is computed in one of the two places, never both. The log mass
// of the data (the log evidence less its constant) is summed in one place,
// CollapsedJoint::weigh(), for the exact posterior (src/exact_posterior.cpp)
// and the stream's evidence alike.
#ifndef GRIDDY_GRID_POSTERIOR_H
#define GRIDDY_GRID_POSTERIOR_H

#include <RcppArmadillo.h>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>
#include "parallel_waves.h"

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

// ---- the log joint over (run, grid point) and its pruned sum --------------
//
// log p(i, g, y) - const = log pi_i + log pi_g - log|R_g| / 2
//                          - (a + n/2) log(b + C_ig / 2)
// over a runs x grid points table C (column-major, N x G). The log joint
// falls with C_ig, so its bound log pi_max + log pi_g - log|R_g|/2
// - (a + n/2) log(b + C_ig/2) is a threshold on C: `known()` finds, per grid
// point, the smallest C (an entry whose value is known) and the largest of
// those, `top()` looks for a larger log joint only among entries whose bound
// exceeds it, and `weigh()` takes logs only of the entries whose bound lies
// less than `negligible` below the top. For the margins and the log mass
// `negligible` is log(N G) + 37 (kNegligibleMass): the entries left out
// weigh less than exp(-37) = 8.5e-17 of the largest together, below the
// rounding of the total, and in a concentrated posterior most entries are.
// Passes over runs go in blocks of kBlockRuns on `threads` threads, with
// each block's sums kept apart and added in block order, so results do not
// depend on the number of threads.
class CollapsedJoint {
 public:
  static constexpr arma::uword kBlockRuns = 4096;
  static constexpr double kNegligibleMass = 37.0;  // plus log(N G)

  CollapsedJoint(const double* C, arma::uword N, arma::uword G, double shape_post,
                 double rate, const double* logdet, const double* log_prior_run,
                 const double* log_prior_grid, int threads)
      : C_(C), N_(N), G_(G), shape_post_(shape_post), rate_(rate), lpr_(log_prior_run),
        threads_(threads), grid_term_(G) {
    lp_max_ = *std::max_element(lpr_, lpr_ + N_);
    for (arma::uword g = 0; g < G_; ++g) {
      grid_term_[g] = grid_log_weight(log_prior_grid[g], logdet[g]);
    }
    n_blocks_ = static_cast<long long>((N_ + kBlockRuns - 1) / kBlockRuns);
    wave_ = std::max<long long>(1, 1e8 / (static_cast<double>(kBlockRuns) * G_));
  }

  arma::uword n_runs() const { return N_; }
  arma::uword n_grid() const { return G_; }
  long long n_blocks() const { return n_blocks_; }

  double log_joint(arma::uword i, arma::uword g, double c) const {
    return grid_term_[g] + lpr_[i] + collapsed_log_fit(c, shape_post_, rate_);
  }

  // log(N G) + 37: what the margins and the log mass may leave out.
  double negligible_mass() const {
    return kNegligibleMass + std::log(static_cast<double>(N_) * G_);
  }

  // The largest log joint (any value near it would do: it only keeps exp()
  // in range): the best of the grid points' smallest-C entries, then a
  // larger one among the entries whose bound exceeds it.
  double top() const {
    std::vector<double> known(G_);
    parallel_waves(G_, G_, threads_, [&](long long g, int) {
      const double* c = C_ + N_ * g;
      const arma::uword i = std::min_element(c, c + N_) - c;
      known[g] = log_joint(i, g, c[i]);
    });
    const double best = *std::max_element(known.begin(), known.end());
    std::vector<double> may_beat(G_);
    for (arma::uword g = 0; g < G_; ++g) may_beat[g] = c_below(g, best);
    std::vector<double> block_max(n_blocks_, best);
    parallel_waves(n_blocks_, wave_, threads_, [&](long long b, int) {
      arma::uword from, to;
      rows_of(b, from, to);
      double m = best;
      for (arma::uword g = 0; g < G_; ++g) {
        const double* c = C_ + N_ * g;
        for (arma::uword i = from; i < to; ++i) {
          if (c[i] < may_beat[g]) m = std::max(m, log_joint(i, g, c[i]));
        }
      }
      block_max[b] = m;
    });
    return *std::max_element(block_max.begin(), block_max.end());
  }

  // Every entry's weight exp(log joint - top), 0 for those more than
  // `negligible` below the top, handed to visit(i, g, w) (each block of runs
  // on one thread: visit may write per-run results without locks); returns
  // the weights summed per grid point, block sums added in block order.
  template <typename Visit>
  std::vector<double> weigh(double top, double negligible, Visit visit) const {
    std::vector<double> cut(G_);
    for (arma::uword g = 0; g < G_; ++g) cut[g] = c_below(g, top - negligible);
    std::vector<double> block_grid(static_cast<std::size_t>(n_blocks_) * G_, 0.0);
    parallel_waves(n_blocks_, wave_, threads_, [&](long long b, int) {
      arma::uword from, to;
      rows_of(b, from, to);
      double* grid_sum = &block_grid[static_cast<std::size_t>(b) * G_];
      for (arma::uword g = 0; g < G_; ++g) {
        const double* c = C_ + N_ * g;
        double sum = 0.0;
        for (arma::uword i = from; i < to; ++i) {
          const double w = c[i] > cut[g] ? 0.0 : std::exp(log_joint(i, g, c[i]) - top);
          visit(i, g, w);
          sum += w;
        }
        grid_sum[g] = sum;
      }
    });
    std::vector<double> grid(G_, 0.0);
    for (long long b = 0; b < n_blocks_; ++b) {
      for (arma::uword g = 0; g < G_; ++g) grid[g] += block_grid[static_cast<std::size_t>(b) * G_ + g];
    }
    return grid;
  }

  // The log mass log sum_{i,g} exp(log joint): the top plus the log of the
  // weights weigh() summed per grid point.
  static double log_mass(double top, const std::vector<double>& grid_sums) {
    double total = 0.0;
    for (double v : grid_sums) total += v;
    return top + std::log(total);
  }

  // The log mass alone: no per-run or per-entry result.
  double log_mass() const {
    const double t = top();
    return log_mass(t, weigh(t, negligible_mass(), [](arma::uword, arma::uword, double) {}));
  }

 private:
  // The C below which an entry's bound exceeds `level` (all C when level is
  // -Inf).
  double c_below(arma::uword g, double level) const {
    if (!std::isfinite(level)) return std::numeric_limits<double>::infinity();
    return 2.0 * (std::exp((grid_term_[g] + lp_max_ - level) / shape_post_) - rate_);
  }

  void rows_of(long long b, arma::uword& from, arma::uword& to) const {
    from = static_cast<arma::uword>(b) * kBlockRuns;
    to = std::min<arma::uword>(N_, from + kBlockRuns);
  }

  const double* C_;
  arma::uword N_, G_;
  double shape_post_, rate_;
  const double* lpr_;
  int threads_;
  std::vector<double> grid_term_;
  double lp_max_;
  long long n_blocks_, wave_;
};

}  // namespace griddy

#endif
