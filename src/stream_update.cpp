// The streaming calibration's hot loops (R/griddy_stream-update.R): one new
// measurement adds one term to every run's quadratic form at every grid
// point, in place, in one pass over the runs; the log evidence is one more
// pass. R checks every index and shape; these functions check only sizes.
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

// log sum over (run i, grid point g) of
//   log_prior_run[i] + grid_term[g] - sum_k shape_post[k] log(rate + C[i, g + G k] / 2),
// the log evidence less its constant. With one noise group, a first pass
// finds each grid point's smallest C, whose term bounds the largest from
// below (`known`); the terms more than log(N G) + 37 below it are left out:
// together they are below exp(-37) ~ 1e-16 of the sum, under the rounding
// of a double, so the result agrees with the full sum to about 1e-16
// (relative). Their logs and exps are the cost: with tau integrated out a
// term falls only as C^-(a + n/2), so late in a stream most runs are cut
// (C above twice the smallest at 120 measurements), early few are.
// [[Rcpp::export]]
double stream_log_sum_cpp(const Rcpp::NumericMatrix& C, const Rcpp::NumericVector& shape_post,
                          double rate, const Rcpp::NumericVector& grid_term,
                          const Rcpp::NumericVector& log_prior_run) {
  const R_xlen_t N = C.nrow(), G = grid_term.size(), K = shape_post.size();
  if (log_prior_run.size() != N || G * K != C.ncol() || N == 0) {
    Rcpp::stop("stream_log_sum: shapes do not match");
  }
  const double* lpr = log_prior_run.begin();
  const double lpr_max = *std::max_element(lpr, lpr + N);
  std::vector<double> cut(G, R_PosInf);
  const double drop = std::log(static_cast<double>(N) * static_cast<double>(G)) + 37.0;
  if (K == 1) {
    double known = R_NegInf;
    for (R_xlen_t g = 0; g < G; ++g) {
      const double* c = C.begin() + N * g;
      const R_xlen_t i = std::min_element(c, c + N) - c;
      known = std::max(known, lpr[i] + grid_term[g] - shape_post[0] * std::log(rate + 0.5 * c[i]));
    }
    for (R_xlen_t g = 0; g < G; ++g) {
      const double room = (lpr_max + grid_term[g] - known + drop) / shape_post[0];
      if (room < 700) cut[g] = 2 * (std::exp(room) - rate);
    }
  }
  double top = R_NegInf, sum = 0;
  std::vector<double> v(N);
  std::vector<R_xlen_t> keep(N);
  for (R_xlen_t g = 0; g < G; ++g) {
    R_xlen_t m = 0;
    const double* c0 = C.begin() + N * g;
    for (R_xlen_t i = 0; i < N; ++i) {
      if (c0[i] <= cut[g]) keep[m++] = i;
    }
    for (R_xlen_t j = 0; j < m; ++j) v[j] = lpr[keep[j]] + grid_term[g];
    for (R_xlen_t k = 0; k < K; ++k) {
      const double* c = C.begin() + N * (g + G * k);
      const double a = shape_post[k];
      for (R_xlen_t j = 0; j < m; ++j) v[j] -= a * std::log(rate + 0.5 * c[keep[j]]);
    }
    if (m == 0) continue;
    const double mx = *std::max_element(v.begin(), v.begin() + m);
    if (!std::isfinite(mx)) continue;
    if (mx > top) {
      sum *= std::exp(top - mx);
      top = mx;
    }
    double s = 0;
    for (R_xlen_t j = 0; j < m; ++j) s += std::exp(v[j] - top);
    sum += s;
  }
  return top + std::log(sum);
}
