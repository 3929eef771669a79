// log sum_i p(run i, grid point g, y) per grid point (R/engine.R,
// grid_log_mass()): the R loop over the columns of C made every column's
// log-likelihood vector and its exponentials in R, a second pass over C as
// long as the fit's own at 5,000 runs x 1,000 grid points. The arithmetic
// is the R code's, operation for operation, and the sum is R's sum() (long
// double, in order), so the values are the same.
#include <Rcpp.h>
#include <cmath>
#include <vector>

// C (runs x grid points), k = a + n/2, cst = log_evidence_constant(),
// logdet per grid point, log prior per run and per grid point.
// [[Rcpp::export]]
Rcpp::NumericVector grid_log_mass_cpp(const Rcpp::NumericMatrix& C, double k, double rate,
                                      double cst, const Rcpp::NumericVector& logdet,
                                      const Rcpp::NumericVector& log_prior_run,
                                      const Rcpp::NumericVector& log_prior_grid) {
  const int runs = C.nrow();
  const int G = C.ncol();
  if (logdet.size() != G || log_prior_grid.size() != G || log_prior_run.size() != runs) {
    Rcpp::stop("grid_log_mass: the lengths do not match C.");
  }
  Rcpp::NumericVector out(G);
  std::vector<double> v(runs);
  const double minus_k = -k;
  for (int g = 0; g < G; ++g) {
    const double* c = C.begin() + static_cast<std::size_t>(g) * runs;
    const double half_logdet = logdet[g] / 2;
    double top = R_NegInf;
    bool nan = false;
    for (int i = 0; i < runs; ++i) {
      double x = minus_k * std::log(rate + c[i] / 2) + cst;
      x = x - half_logdet;
      x = x + log_prior_run[i];
      x = x + log_prior_grid[g];
      v[i] = x;
      if (std::isnan(x)) nan = true; else if (x > top) top = x;
    }
    if (runs == 0) { out[g] = R_NegInf; continue; }
    // max() of a vector with NaN is NaN (NA before NaN aside), not finite
    if (nan) { out[g] = R_NaN; continue; }
    if (!std::isfinite(top)) { out[g] = top; continue; }
    long double s = 0.0;
    for (int i = 0; i < runs; ++i) s += std::exp(v[i] - top);
    out[g] = top + std::log(static_cast<double>(s));
  }
  return out;
}
