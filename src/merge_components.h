// The binning of next_measurement()'s mixture components, shared by
// merge_components_cpp() and next_gains_cpp() (see merge_components.cpp).
//
// Concentrated or not, the first pass merges the components straight into
// the bins of the first widths through a table of at most
// 2 x `max_components` entries (in L1), in order of first appearance. Most
// calls end there: with next_measurement()'s components, a few hundred
// thousand of them, that one read is the whole cost of the merge (a bitmap
// count of the occupied bins over 10^7 of them, then this table, cost two
// reads, the first with a cache miss per component).
//
// When more bins are occupied, the pass stops at the first one too many;
// the widths grow until the grid has at most 2^16 bins, and one pass sums
// each component into its bin of that grid (a dense table). The widening
// that follows (the same rule) bins those sums, each at its weighted mean
// location and log scale, not the components again: a component then
// lands in the bin of its fine bin's mean, not always its own, which
// changes which near-boundary components go together but not that a
// merged component has exactly its members' weight, mean and variance.
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

// The range of the components' locations and log scales, which sets the
// grid (next_gains_cpp() gathers it as it computes them).
struct Bounds {
  double m_min = INFINITY, m_max = -INFINITY, ls_min = INFINITY, ls_max = -INFINITY;
  void add(double m, double ls) {
    m_min = std::min(m_min, m);
    m_max = std::max(m_max, m);
    ls_min = std::min(ls_min, ls);
    ls_max = std::max(ls_max, ls);
  }
};

namespace merge_detail {

const double kMaxBins = 1e7;      // the first pass's grid at most
const double kDenseBins = 65536;  // the dense table's bins

// A grid of bins: (class, log-scale bin sb, location bin of width h[sb]).
struct Grid {
  double ls_min, m_min, ls_max, m_max, wl, ws, inv_ws = 1;
  int n_classes, span_sb = 1, span_mb = 1;
  std::vector<double> inv_h;
  double bins() const {
    const double n_sb = std::floor((ls_max - ls_min) / ws) + 1.0;
    const double n_mb = std::floor((m_max - m_min) / (wl * std::exp(ls_min))) + 1.0;
    return n_classes * n_sb * n_mb;
  }
  void widen(double f) {
    wl *= f;
    ws *= f;
  }
  // widths grown (by the widening rule) until the grid has at most `cap` bins
  void cap_bins(double cap) {
    for (int iter = 0; iter < 200 && bins() > cap; ++iter) widen(std::sqrt(bins() / cap) * 1.1);
  }
  void fix() {
    span_sb = static_cast<int>(std::floor((ls_max - ls_min) / ws) + 1.0);
    span_mb = static_cast<int>(std::floor((m_max - m_min) / (wl * std::exp(ls_min))) + 1.0);
    inv_ws = 1 / ws;
    inv_h.resize(span_sb);
    for (int b = 0; b < span_sb; ++b) inv_h[b] = 1 / (wl * std::exp(ls_min + b * ws));
  }
  int key(double ls, double m, int cls) const {
    const int sb = std::min(static_cast<int>((ls - ls_min) * inv_ws), span_sb - 1);
    const int mb = std::min(static_cast<int>((m - m_min) * inv_h[sb]), span_mb - 1);
    return ((cls - 1) * span_sb + sb) * span_mb + mb;
  }
  int class_of(int key) const { return key / (span_sb * span_mb) + 1; }
};

// Occupied bins of keys key(i), i < n, counted up to `stop` (then stop + 1).
template <class Key>
long count_bins(const Grid& grid, long n, Key key, long stop) {
  static thread_local std::vector<uint64_t> bits;
  const size_t n_words = static_cast<size_t>(grid.n_classes) * grid.span_sb * grid.span_mb / 64 + 1;
  if (bits.size() < n_words) bits.resize(n_words);
  std::fill(bits.begin(), bits.begin() + n_words, 0);
  long n_key = 0;
  for (long i = 0; i < n; ++i) {
    const int k = key(i);
    const uint64_t bit = uint64_t(1) << (k & 63);
    if (!(bits[k >> 6] & bit)) {
      bits[k >> 6] |= bit;
      if (++n_key > stop) break;
    }
  }
  return n_key;
}

// An open-addressing table from bin keys to slots 0, 1, ..., numbered in
// order of first appearance, sized for `capacity` keys.
class SlotTable {
 public:
  explicit SlotTable(long capacity) {
    while (size_ < 2 * static_cast<size_t>(capacity)) size_ *= 2;
    key_.assign(size_, -1);
    slot_.resize(size_);
  }
  // The slot of key k; a new one when k is new (`added` says so), or -1
  // when k is new and `limit` slots are taken.
  int slot(int k, int limit, bool& added) {
    size_t p = (static_cast<uint32_t>(k) * 2654435761u) & (size_ - 1);
    while (key_[p] >= 0 && key_[p] != k) p = (p + 1) & (size_ - 1);
    added = key_[p] < 0;
    if (added) {
      if (used_ == limit) return -1;
      key_[p] = k;
      slot_[p] = used_++;
    }
    return slot_[p];
  }
  int used() const { return used_; }

 private:
  size_t size_ = 16;
  std::vector<int> key_, slot_;
  int used_ = 0;
};

// Bins in order of first appearance: slot[i] for each i < n; returns the
// number of bins.
template <class Key>
int assign_bins(long n, Key key, long n_key, std::vector<int>& slot) {
  SlotTable table(n_key);
  slot.resize(n);
  bool added;
  for (long i = 0; i < n; ++i) slot[i] = table.slot(key(i), -1, added);
  return table.used();
}

// A bin's sums of w, w m, w m^2, w s^2 and w log s over its members.
struct Sums {
  double w, wm, wm2, ws2, wls;
  long count;
  void add(double wi, double mi, double si, double lsi) {
    w += wi;
    wm += wi * mi;
    wm2 += wi * mi * mi;
    ws2 += wi * si * si;
    wls += wi * lsi;
  }
  void add(const Sums& b) {
    w += b.w;
    wm += b.wm;
    wm2 += b.wm2;
    ws2 += b.ws2;
    wls += b.wls;
  }
};
const Sums kEmpty = {0, 0, 0, 0, 0, 0};

// The merged components from their bins' sums: each with its members'
// weight, mean and variance (mean square scale plus the locations' variance).
inline void finish(const std::vector<Sums>& sums, const std::vector<int>& cls, Merged& out) {
  const size_t J = sums.size();
  out.w.resize(J);
  out.m.resize(J);
  out.s2.resize(J);
  out.nu_class = cls;
  for (size_t j = 0; j < J; ++j) {
    const Sums& b = sums[j];
    out.w[j] = b.w;
    out.m[j] = b.wm / b.w;
    out.s2[j] = b.ws2 / b.w + std::max(b.wm2 / b.w - out.m[j] * out.m[j], 0.0);
  }
}

// One pass that merges straight into at most `max_components` bins
// through an open-addressing table small enough for L1 (in order of first
// appearance); false, with `out` unfinished, as soon as one more is needed.
template <class Key>
bool merge_small(const Grid& grid, const double* w, const double* m, const double* s,
                 const double* ls, Key key, long n, int max_components, Merged& out) {
  SlotTable table(max_components);
  std::vector<Sums> sums(max_components, kEmpty);
  std::vector<int> cls(max_components, 0);
  bool added;
  for (long i = 0; i < n; ++i) {
    const int k = key(i);
    const int j = table.slot(k, max_components, added);
    if (j < 0) return false;
    if (added) cls[j] = grid.class_of(k);
    sums[j].add(w[i], m[i], s[i], ls[i]);
  }
  sums.resize(table.used());
  cls.resize(table.used());
  finish(sums, cls, out);
  return true;
}

}  // namespace merge_detail

inline void merge_components(const double* w, const double* m, const double* s,
                             const double* ls, const int* nu_class, long n, int n_classes,
                             double width_location, double width_scale,
                             int max_components, Merged& out,
                             const Bounds* known = nullptr) {
  using namespace merge_detail;
  Bounds bounds;
  if (known) {
    bounds = *known;
  } else {
    for (long i = 0; i < n; ++i) bounds.add(m[i], ls[i]);
  }
  Grid grid;
  grid.ls_min = bounds.ls_min;
  grid.ls_max = bounds.ls_max;
  grid.m_min = bounds.m_min;
  grid.m_max = bounds.m_max;
  grid.n_classes = n_classes;
  grid.wl = width_location;
  grid.ws = width_scale;
  grid.cap_bins(kMaxBins);
  auto raw_key = [&](long i) { return grid.key(ls[i], m[i], nu_class[i]); };
  grid.fix();
  if (merge_small(grid, w, m, s, ls, raw_key, n, max_components, out)) return;
  grid.cap_bins(kDenseBins);
  // the dense table: each component's sums into its bin of a grid of at
  // most 2^16 bins, one cache line a bin (bins in order of first appearance)
  grid.fix();
  static thread_local std::vector<Sums> dense;
  const size_t n_bins = static_cast<size_t>(n_classes) * grid.span_sb * grid.span_mb;
  if (dense.size() < n_bins) dense.resize(n_bins, kEmpty);
  std::vector<int> touched;
  for (long i = 0; i < n; ++i) {
    const int k = raw_key(i);
    Sums& b = dense[k];
    if (b.count++ == 0) touched.push_back(k);
    b.add(w[i], m[i], s[i], ls[i]);
  }
  const long n_fine = touched.size();
  std::vector<Sums> fine(n_fine);
  std::vector<int> fcls(n_fine);
  for (long j = 0; j < n_fine; ++j) {
    fine[j] = dense[touched[j]];
    fcls[j] = grid.class_of(touched[j]);
    dense[touched[j]] = kEmpty;
  }
  if (n_fine <= max_components) {
    finish(fine, fcls, out);
    return;
  }
  // widen over the fine bins, each at its weighted mean location and log scale
  std::vector<double> mean_m(n_fine), mean_ls(n_fine);
  for (long j = 0; j < n_fine; ++j) {
    mean_m[j] = fine[j].wm / fine[j].w;
    mean_ls[j] = fine[j].wls / fine[j].w;
  }
  auto fine_key = [&](long j) { return grid.key(mean_ls[j], mean_m[j], fcls[j]); };
  long n_key = n_fine;
  for (int iter = 0; iter < 200 && n_key > max_components; ++iter) {
    grid.widen(std::sqrt(static_cast<double>(n_key) / max_components) * 1.1);
    grid.fix();
    n_key = count_bins(grid, n_fine, fine_key, n_fine);
  }
  std::vector<int> slot;
  const int used = assign_bins(n_fine, fine_key, n_key, slot);
  std::vector<Sums> merged(used, kEmpty);
  std::vector<int> cls(used, 0);
  for (long j = 0; j < n_fine; ++j) {
    merged[slot[j]].add(fine[j]);
    cls[slot[j]] = fcls[j];
  }
  finish(merged, cls, out);
}

}  // namespace griddy
#endif
