// One read of every element of a matrix, the unit in which bench/ states
// how many passes over memory a computation costs: a plain loop, sums in
// four lanes so that the additions do not wait on each other (R's sum()
// adds in long double, one element at a time, and is about 3 times slower,
// so it understates a pass's speed). For benchmarks only (unexported).
#include <Rcpp.h>

// [[Rcpp::export]]
double memory_pass_cpp(Rcpp::NumericMatrix y) {
  const double* p = y.begin();
  const R_xlen_t n = y.size();
  double s0 = 0, s1 = 0, s2 = 0, s3 = 0;
  R_xlen_t i = 0;
  for (; i + 4 <= n; i += 4) {
    s0 += p[i];
    s1 += p[i + 1];
    s2 += p[i + 2];
    s3 += p[i + 3];
  }
  for (; i < n; ++i) s0 += p[i];
  return (s0 + s1) + (s2 + s3);
}
