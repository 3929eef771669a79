// The runs that can be among the k nearest to one run in the library's
// scaled parameter space (R/discrepancy.R, near_candidates()): one read of
// the parameter columns and a partial sort, where R's vector arithmetic
// over 10^6 runs took longer than a pass over the library's outputs.
#include <Rcpp.h>
#include <algorithm>
#include <vector>

// cols: the varying parameters' columns (finite; validated with the
// library), span: their ranges, best: the run (1-based), k: how many
// nearest, slack: the rounding allowed above the k-th squared distance.
// Returns the candidates' 1-based positions in increasing order.
// [[Rcpp::export]]
Rcpp::IntegerVector near_candidates_cpp(Rcpp::List cols, Rcpp::NumericVector span, int best,
                                        int k, double slack) {
  const int p = cols.size();
  if (p == 0 || span.size() != p) Rcpp::stop("near_candidates: one span per column");
  const R_xlen_t n = Rcpp::NumericVector(cols[0]).size();
  if (best < 1 || best > n || k < 1) Rcpp::stop("near_candidates: best or k out of range");
  std::vector<double> d2(n, 0.0);
  for (int j = 0; j < p; ++j) {
    Rcpp::NumericVector v(cols[j]);
    if (v.size() != n) Rcpp::stop("near_candidates: columns of unequal length");
    const double at = v[best - 1], s = span[j];
    for (R_xlen_t i = 0; i < n; ++i) {
      const double z = (v[i] - at) / s;
      d2[i] += z * z;
    }
  }
  if (n <= k) return Rcpp::seq_len(n);
  std::vector<double> sorted(d2);
  std::nth_element(sorted.begin(), sorted.begin() + (k - 1), sorted.end());
  const double cut = sorted[k - 1] + slack;
  std::vector<int> out;
  for (R_xlen_t i = 0; i < n; ++i) {
    if (d2[i] <= cut) out.push_back(static_cast<int>(i + 1));
  }
  return Rcpp::wrap(out);
}
