// The streaming calibration's hot loop (R/stream-update.R): each new
// measurement adds one term to every run's quadratic form at every grid
// point, in place. The measurements of one update() go in one pass over the
// runs (a block of runs at a time, every measurement in arrival order within
// it), so a batch costs one read of the forms, not one per measurement, and
// each form gets its terms in the order a measurement at a time gives them.
// The log evidence is not here: it is the exact posterior's log mass
// (log_mass_cpp(), the one pruned sum of grid_posterior.h). R checks every
// index and shape; this checks only sizes.
#include <Rcpp.h>
#include <algorithm>
#include <cmath>
#include <vector>

// Add measurements m = 1..M (values y[m] at library output columns
// column[m], 0-based) to the forms C (N runs x G K grid points: one block
// of G columns per noise group, measurement m's starting at column
// offset[m]): C[i, offset[m] + g] += e^2 scale(g, m) with e = (y[m] -
// out[i, column[m]]) - phi(g, m) (y_prev[m] - out[i, prev[m]]), the AR(1)
// innovation given the previous measurement at that setting and group
// (prev[m] = -1: none, e = the residual); scale(g, m) = 1 / (1 - phi^2) (1
// without a previous measurement). phi and scale are G x M.
// [[Rcpp::export]]
void stream_add_cpp(Rcpp::NumericMatrix C, const Rcpp::NumericMatrix& outputs,
                    const Rcpp::IntegerVector& column, const Rcpp::NumericVector& y,
                    const Rcpp::IntegerVector& prev, const Rcpp::NumericVector& y_prev,
                    const Rcpp::NumericMatrix& phi, const Rcpp::NumericMatrix& scale,
                    const Rcpp::IntegerVector& offset) {
  const R_xlen_t N = outputs.nrow();
  const R_xlen_t M = column.size();
  const R_xlen_t G = phi.nrow();
  bool ok = C.nrow() == N && y.size() == M && prev.size() == M && y_prev.size() == M &&
    phi.ncol() == M && scale.nrow() == G && scale.ncol() == M && offset.size() == M;
  for (R_xlen_t m = 0; ok && m < M; ++m) {
    ok = offset[m] >= 0 && offset[m] + G <= C.ncol() && column[m] >= 0 &&
      column[m] < outputs.ncol() && prev[m] < outputs.ncol();
  }
  if (!ok) Rcpp::stop("stream_add: shapes do not match");
  const R_xlen_t block = 2048;
  std::vector<double> r(block), q(block);
  bool finite = true;
  for (R_xlen_t start = 0; start < N; start += block) {
    const R_xlen_t len = std::min(block, N - start);
    for (R_xlen_t m = 0; m < M; ++m) {
      const double* cur = outputs.begin() + N * static_cast<R_xlen_t>(column[m]) + start;
      const double* old = prev[m] >= 0 ?
        outputs.begin() + N * static_cast<R_xlen_t>(prev[m]) + start : nullptr;
      const double ym = y[m];
      for (R_xlen_t i = 0; i < len; ++i) r[i] = ym - cur[i];
      if (old) {
        const double yp = y_prev[m];
        for (R_xlen_t i = 0; i < len; ++i) q[i] = yp - old[i];
      }
      double* c = C.begin() + N * static_cast<R_xlen_t>(offset[m]) + start;
      for (R_xlen_t g = 0; g < G; ++g) {
        double* cg = c + N * g;
        const double f = phi(g, m), s = scale(g, m);
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
  }
  if (!finite) Rcpp::stop("stream_add: a misfit is not finite");
}
