// Inverse-CDF draws over a discrete set (library runs or correlation grid
// points): the Griddy Gibbs step of the thesis (Appendix A.3).
#ifndef GRIDDY_INVERSE_CDF_H
#define GRIDDY_INVERSE_CDF_H

#include <RcppArmadillo.h>
#include <algorithm>

namespace griddy {

// First index whose cumulative weight exceeds u * total. `cdf` holds
// unnormalised cumulative sums, so weights of zero are never drawn.
inline arma::uword draw_from_cdf(const double* cdf, arma::uword n) {
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

}  // namespace griddy

#endif
