// The streaming calibration's hot loops (R/stream-update.R): one new
// measurement adds one term to every run's quadratic form at every grid
// point, in place, in one pass over the runs. The log evidence is not here:
// it is the exact posterior's log mass (log_mass_cpp(), the one pruned sum of
// grid_posterior.h). R checks every index and shape; this checks only sizes.
#include <Rcpp.h>
#include <algorithm>
#include <cmath>
#include <vector>

// Add one measurement y at library output column `column` (0-based) to the
// forms C (N runs x G grid points, the block of one noise group, starting at
// column `offset` of the N x (G K) table): C[i, g] += e_ig^2 * scale[g] with
// e_ig = (y - out[i, column]) - phi[g] (y_prev - out[i, prev]) -- the AR(1)
// innovation given the previous measurement at that setting and group (prev
// = -1: none, e = the residual). scale[g] = 1 / (1 - phi[g]^2) (1 without a
// previous measurement). The runs go in blocks so that the residuals are
// computed once for all grid points.
// [[Rcpp::export]]
void stream_add_cpp(Rcpp::NumericMatrix C, const Rcpp::NumericMatrix& outputs, int column,
                    double y, int prev, double y_prev, const Rcpp::NumericVector& phi,
                    const Rcpp::NumericVector& scale, int offset) {
  const R_xlen_t N = outputs.nrow();
  const R_xlen_t G = phi.size();
  if (C.nrow() != N || offset < 0 || offset + G > C.ncol() || scale.size() != G ||
      column < 0 || column >= outputs.ncol() || prev >= outputs.ncol()) {
    Rcpp::stop("stream_add: shapes do not match");
  }
  const double* cur = outputs.begin() + N * static_cast<R_xlen_t>(column);
  const double* old = prev >= 0 ? outputs.begin() + N * static_cast<R_xlen_t>(prev) : nullptr;
  double* c = C.begin() + N * static_cast<R_xlen_t>(offset);
  const R_xlen_t block = 2048;
  std::vector<double> r(block), q(block);
  bool finite = true;
  for (R_xlen_t start = 0; start < N; start += block) {
    const R_xlen_t len = std::min(block, N - start);
    for (R_xlen_t i = 0; i < len; ++i) r[i] = y - cur[start + i];
    if (old) for (R_xlen_t i = 0; i < len; ++i) q[i] = y_prev - old[start + i];
    for (R_xlen_t g = 0; g < G; ++g) {
      double* cg = c + N * g + start;
      const double f = phi[g], s = scale[g];
      if (old && f != 0) {
        for (R_xlen_t i = 0; i < len; ++i) {
          const double e = r[i] - f * q[i];
          cg[i] += e * e * s;
        }
      } else {
        for (R_xlen_t i = 0; i < len; ++i) cg[i] += r[i] * r[i] * s;
      }
      finite = finite && std::isfinite(cg[len - 1]);
    }
  }
  if (!finite) Rcpp::stop("stream_add: a misfit is not finite");
}
