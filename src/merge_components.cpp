// The merging of next_measurement()'s mixture components (R/next-measurement.R,
// merge_components()): one pass over the components per bin width, with no
// hash and no temporary as long as the components, so that 10^5 components
// per candidate cost about a millisecond.
//
// A component falls in the bin of (degrees-of-freedom class, log-scale bin
// sb = floor((log s - min log s) / ws), location bin floor((m - min m) / h)
// with h = wl exp(min log s + sb ws)). While more than `max_components`
// bins are occupied (or more than 10^7 exist), the widths grow by
// sqrt(occupied / max) x 1.1. The merged component has the bin's weight,
// mean, and squared scale (weighted mean square scale plus the locations'
// variance).
#include <Rcpp.h>
#include <algorithm>
#include <cmath>
#include <vector>

// [[Rcpp::export]]
Rcpp::List merge_components_cpp(Rcpp::NumericVector w, Rcpp::NumericVector m,
                                Rcpp::NumericVector s, Rcpp::NumericVector ls,
                                Rcpp::IntegerVector nu_class,
                                int n_classes, double width_location, double width_scale,
                                int max_components) {
  const R_xlen_t n = w.size();
  double ls_min = R_PosInf, ls_max = R_NegInf, m_min = R_PosInf, m_max = R_NegInf;
  for (R_xlen_t i = 0; i < n; ++i) {
    ls_min = std::min(ls_min, ls[i]);
    ls_max = std::max(ls_max, ls[i]);
    m_min = std::min(m_min, m[i]);
    m_max = std::max(m_max, m[i]);
  }
  std::vector<int> key(n);
  std::vector<int> slot;      // bin -> merged component (-1: empty), reset where touched
  std::vector<int> touched;
  std::vector<double> h;      // the location width of each scale bin
  int n_key = 0;
  for (int iter = 0; iter < 200; ++iter) {
    const double n_sb = std::floor((ls_max - ls_min) / width_scale) + 1.0;
    // the widest location span: the smallest scale bin's width
    const double n_mb = std::floor((m_max - m_min) / (width_location * std::exp(ls_min))) + 1.0;
    const double n_bins = n_classes * n_sb * n_mb;
    if (n_bins > 1e7) {
      const double f = std::sqrt(n_bins / 1e7) * 1.1;
      width_location *= f;
      width_scale *= f;
      continue;
    }
    const int span_mb = static_cast<int>(n_mb);
    const int span_sb = static_cast<int>(n_sb);
    if (slot.size() < static_cast<size_t>(n_bins)) slot.resize(static_cast<size_t>(n_bins), -1);
    h.resize(span_sb);
    for (int b = 0; b < span_sb; ++b) h[b] = width_location * std::exp(ls_min + b * width_scale);
    for (int k : touched) slot[k] = -1;
    touched.clear();
    n_key = 0;
    for (R_xlen_t i = 0; i < n; ++i) {
      const int sb = std::min(static_cast<int>((ls[i] - ls_min) / width_scale), span_sb - 1);
      const int mb = std::min(static_cast<int>((m[i] - m_min) / h[sb]), span_mb - 1);
      const int k = ((nu_class[i] - 1) * span_sb + sb) * span_mb + mb;
      if (slot[k] < 0) {
        slot[k] = n_key++;
        touched.push_back(k);
      }
      key[i] = slot[k];
    }
    if (n_key <= max_components) break;
    const double f = std::sqrt(static_cast<double>(n_key) / max_components) * 1.1;
    width_location *= f;
    width_scale *= f;
  }
  Rcpp::NumericVector W(n_key), M(n_key), M2(n_key), S2(n_key);
  Rcpp::IntegerVector cls(n_key);
  for (R_xlen_t i = 0; i < n; ++i) {
    const int k = key[i];
    W[k] += w[i];
    M[k] += w[i] * m[i];
    M2[k] += w[i] * m[i] * m[i];
    S2[k] += w[i] * s[i] * s[i];
    cls[k] = nu_class[i];
  }
  for (int k = 0; k < n_key; ++k) {
    M[k] /= W[k];
    S2[k] = S2[k] / W[k] + std::max(M2[k] / W[k] - M[k] * M[k], 0.0);
  }
  return Rcpp::List::create(Rcpp::Named("w") = W, Rcpp::Named("m") = M,
                            Rcpp::Named("s2") = S2, Rcpp::Named("nu_class") = cls);
}
