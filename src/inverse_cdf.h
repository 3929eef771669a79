// Inverse-CDF draws over a discrete set (library runs or correlation grid
// points): the Griddy Gibbs step of the thesis (Appendix A.3).
#ifndef GRIDDY_INVERSE_CDF_H
#define GRIDDY_INVERSE_CDF_H

#include <RcppArmadillo.h>
#include <algorithm>
#include <cmath>
#include <limits>

namespace griddy {

// First index whose cumulative weight exceeds u * total. `cdf` holds
// unnormalised cumulative sums, so weights of zero are never drawn.
inline arma::uword draw_from_cdf(const double* cdf, arma::uword n) {
  // R validates C before any chain runs; this guards the invariant that a draw
  // never returns an entry of zero weight (the last, with no weight at all)
  if (n == 0 || !(cdf[n - 1] > 0.0) || !std::isfinite(cdf[n - 1])) {
    Rcpp::stop("griddy internal error: a sampler draw's weights sum to %g over %d "
               "entries (zero or non-finite weights should have been refused by R's checks); "
               "please report it with the call that gave it", n ? cdf[n - 1] : 0.0,
               static_cast<int>(n));
  }
  const double target = R::unif_rand() * cdf[n - 1];
  const double* hit = std::upper_bound(cdf, cdf + n, target);
  return std::min<arma::uword>(static_cast<arma::uword>(hit - cdf), n - 1);
}

// Weights below exp(-700) of the largest are set to zero without calling exp:
// their sum stays below 1e-300 of the total for any library that fits in
// memory, and exp of such arguments (subnormal results) is very slow.
constexpr double negligible_log_weight = -700.0;

// Shift log weights by their maximum (so the largest weight is 1 and nothing
// overflows), exponentiate, accumulate into `work`, then draw.
inline void cumulative_weights(const double* log_w, arma::uword n, double* cdf) {
  const double top = *std::max_element(log_w, log_w + n);
  double total = 0.0;
  for (arma::uword i = 0; i < n; ++i) {
    const double d = log_w[i] - top;
    if (d > negligible_log_weight) total += std::exp(d);
    cdf[i] = total;
  }
}

inline arma::uword draw_from_log_weights(const double* log_w, arma::uword n,
                                         double* work) {
  cumulative_weights(log_w, n, work);
  return draw_from_cdf(work, n);
}

// Truncation of a draw over runs sorted by C (ascending), whose weights
// w_i = pi_i f(C_i) fall with C. With w_(1) the weight of the first run in
// sorted order and pi_max the largest prior weight, every run whose weight
// bound pi_max f(C_i) is below tol / N * w_(1) is left out: together they
// hold less than tol * w_(1) <= tol * (total weight), so the truncated draw
// is the exact draw conditioned on an event of probability > 1 - tol, and
// their total-variation distance is below tol. `log_budget` is
// log(N / tol) + log(pi_max / pi_(1)): how far (in log weight) below the
// first run a run may fall and still be kept. Infinite when tol is 0 or the
// first run has prior weight 0 (no truncation).
inline double log_budget(arma::uword n, double tol, double log_prior_max,
                         double log_prior_first) {
  if (!(tol > 0.0) || !std::isfinite(log_prior_first)) {
    return std::numeric_limits<double>::infinity();
  }
  return std::log(static_cast<double>(n)) - std::log(tol) + log_prior_max - log_prior_first;
}

// Number of leading entries of the sorted column (values c[order[k]]) that
// are <= cut: a binary search, so a draw touches only the head of the list.
inline arma::uword head_length(const double* c, const int* order, arma::uword n,
                               double cut) {
  if (!(cut < std::numeric_limits<double>::infinity())) return n;
  arma::uword lo = 0, hi = n;  // answer in [lo, hi]
  while (lo < hi) {
    const arma::uword mid = lo + (hi - lo) / 2;
    if (c[order[mid]] <= cut) lo = mid + 1; else hi = mid;
  }
  return std::max<arma::uword>(lo, 1);
}

}  // namespace griddy

#endif
