// The streaming calibration's hot loops (R/griddy_stream-update.R): one new
// measurement adds one term to every run's quadratic form at every grid
// point, in place, in one pass over the runs; the log evidence is one more
// pass. R checks every index and shape; these functions check only sizes.
#include <Rcpp.h>
#include <algorithm>
#include "parallel_waves.h"
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
// The runs go in blocks (items of parallel_waves(), on `threads` threads);
// each block's terms are summed relative to the block's own largest, and
// the blocks are combined in order afterwards, so the result does not
// depend on the number of threads.
// [[Rcpp::export]]
double stream_log_sum_cpp(const Rcpp::NumericMatrix& C, const Rcpp::NumericVector& shape_post,
                          double rate, const Rcpp::NumericVector& grid_term,
                          const Rcpp::NumericVector& log_prior_run, int threads = 1) {
  const R_xlen_t N = C.nrow(), G = grid_term.size(), K = shape_post.size();
  if (log_prior_run.size() != N || G * K != C.ncol() || N == 0) {
    Rcpp::stop("stream_log_sum: shapes do not match");
  }
  const double* lpr = log_prior_run.begin();
  const double* c_all = C.begin();
  const double* a_all = shape_post.begin();
  const double* gt = grid_term.begin();
  const double lpr_max = *std::max_element(lpr, lpr + N);
  std::vector<double> cut(G, R_PosInf);
  const double drop = std::log(static_cast<double>(N) * static_cast<double>(G)) + 37.0;
  if (K == 1) {
    double known = R_NegInf;
    for (R_xlen_t g = 0; g < G; ++g) {
      const double* c = c_all + N * g;
      const R_xlen_t i = std::min_element(c, c + N) - c;
      known = std::max(known, lpr[i] + gt[g] - a_all[0] * std::log(rate + 0.5 * c[i]));
    }
    for (R_xlen_t g = 0; g < G; ++g) {
      const double room = (lpr_max + gt[g] - known + drop) / a_all[0];
      if (room < 700) cut[g] = 2 * (std::exp(room) - rate);
    }
  }
  const R_xlen_t block = 16384;
  const R_xlen_t n_blocks = (N + block - 1) / block;
  const int n_threads = griddy::usable_threads(threads);
  std::vector<std::vector<double>> work(n_threads, std::vector<double>(block));
  std::vector<double> block_top(n_blocks * G, R_NegInf), block_sum(n_blocks * G, 0.0);
  griddy::parallel_waves(n_blocks * G, 64LL * n_threads, n_threads, [&](long long item, int thread) {
    const R_xlen_t g = item / n_blocks, b = item % n_blocks;
    const R_xlen_t start = b * block, len = std::min(block, N - start);
    double* v = work[thread].data();
    const double* c0 = c_all + N * g + start;
    double mx = R_NegInf;
    for (R_xlen_t i = 0; i < len; ++i) {
      if (!(c0[i] <= cut[g])) {
        v[i] = R_NegInf;
        continue;
      }
      double term = lpr[start + i] + gt[g];
      for (R_xlen_t k = 0; k < K; ++k) {
        term -= a_all[k] * std::log(rate + 0.5 * c_all[N * (g + G * k) + start + i]);
      }
      v[i] = term;
      mx = std::max(mx, term);
    }
    if (!std::isfinite(mx)) return;
    double sum = 0;
    for (R_xlen_t i = 0; i < len; ++i) {
      if (v[i] > R_NegInf) sum += std::exp(v[i] - mx);
    }
    block_top[item] = mx;
    block_sum[item] = sum;
  });
  const double top = *std::max_element(block_top.begin(), block_top.end());
  if (!std::isfinite(top)) return top;
  double sum = 0;
  for (R_xlen_t item = 0; item < n_blocks * G; ++item) {
    if (block_sum[item] > 0) sum += block_sum[item] * std::exp(block_top[item] - top);
  }
  return top + std::log(sum);
}
