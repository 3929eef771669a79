// The binning of next_measurement()'s mixture components, shared by
// merge_components_cpp() and next_gains_cpp() (see merge_components.cpp).
// Occupied bins are counted in a bitmap (1e7 bins: 1.25 MB, in cache),
// and only the last pass, with few bins, assigns the merged components
// (in order of first appearance) through a small open-addressing table.
#ifndef GRIDDY_MERGE_COMPONENTS_H
#define GRIDDY_MERGE_COMPONENTS_H
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace griddy {

struct Merged {
  std::vector<double> w, m, s2;
  std::vector<int> nu_class;
};

inline void merge_components(const double* w, const double* m, const double* s,
                             const double* ls, const int* nu_class, long n, int n_classes,
                             double width_location, double width_scale,
                             int max_components, Merged& out) {
  double ls_min = INFINITY, ls_max = -INFINITY, m_min = INFINITY, m_max = -INFINITY;
  for (long i = 0; i < n; ++i) {
    ls_min = std::min(ls_min, ls[i]);
    ls_max = std::max(ls_max, ls[i]);
    m_min = std::min(m_min, m[i]);
    m_max = std::max(m_max, m[i]);
  }
  static thread_local std::vector<uint64_t> bits;
  std::vector<double> h;
  int span_mb = 1, span_sb = 1;
  auto bin = [&](long i) {
    const int sb = std::min(static_cast<int>((ls[i] - ls_min) / width_scale), span_sb - 1);
    const int mb = std::min(static_cast<int>((m[i] - m_min) / h[sb]), span_mb - 1);
    return ((nu_class[i] - 1) * span_sb + sb) * span_mb + mb;
  };
  long n_key = 0;
  for (int iter = 0; iter < 200; ++iter) {
    const double n_sb = std::floor((ls_max - ls_min) / width_scale) + 1.0;
    const double n_mb = std::floor((m_max - m_min) / (width_location * std::exp(ls_min))) + 1.0;
    const double n_bins = n_classes * n_sb * n_mb;
    if (n_bins > 1e7) {
      const double f = std::sqrt(n_bins / 1e7) * 1.1;
      width_location *= f;
      width_scale *= f;
      continue;
    }
    span_mb = static_cast<int>(n_mb);
    span_sb = static_cast<int>(n_sb);
    h.resize(span_sb);
    for (int b = 0; b < span_sb; ++b) h[b] = width_location * std::exp(ls_min + b * width_scale);
    const size_t n_words = static_cast<size_t>(n_bins) / 64 + 1;
    if (bits.size() < n_words) bits.resize(n_words);
    std::fill(bits.begin(), bits.begin() + n_words, 0);
    n_key = 0;
    for (long i = 0; i < n; ++i) {
      const int k = bin(i);
      const uint64_t bit = uint64_t(1) << (k & 63);
      if (!(bits[k >> 6] & bit)) {
        bits[k >> 6] |= bit;
        ++n_key;
      }
    }
    if (n_key <= max_components) break;
    const double f = std::sqrt(static_cast<double>(n_key) / max_components) * 1.1;
    width_location *= f;
    width_scale *= f;
  }
  // the last pass: bin -> merged component, in order of first appearance
  size_t size = 16;
  while (size < 2 * static_cast<size_t>(n_key)) size *= 2;
  std::vector<int> table_key(size, -1), table_slot(size);
  out.w.assign(n_key, 0.0);
  out.m.assign(n_key, 0.0);
  out.s2.assign(n_key, 0.0);
  out.nu_class.assign(n_key, 0);
  std::vector<double> m2(n_key, 0.0);
  int used = 0;
  for (long i = 0; i < n; ++i) {
    const int k = bin(i);
    size_t p = (static_cast<uint32_t>(k) * 2654435761u) & (size - 1);
    while (table_key[p] >= 0 && table_key[p] != k) p = (p + 1) & (size - 1);
    if (table_key[p] < 0) {
      table_key[p] = k;
      table_slot[p] = used++;
    }
    const int j = table_slot[p];
    out.w[j] += w[i];
    out.m[j] += w[i] * m[i];
    m2[j] += w[i] * m[i] * m[i];
    out.s2[j] += w[i] * s[i] * s[i];
    out.nu_class[j] = nu_class[i];
  }
  for (long j = 0; j < n_key; ++j) {
    out.m[j] /= out.w[j];
    out.s2[j] = out.s2[j] / out.w[j] + std::max(m2[j] / out.w[j] - out.m[j] * out.m[j], 0.0);
  }
}

}  // namespace griddy
#endif
