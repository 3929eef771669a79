// The runs' products of diagnose_gap()'s "other" model (R/gap-other.R,
// kronecker_products()): for every run j, with its residual E_j = y - Y_j as
// an n_t x n_x matrix (column k the residuals at x setting k), and for every
// term m (a kernel at a grid point),
//   Z_j = Mt_m' E_j Mx_m            (rt_m x rx_m)
//   drop_j(m, s) = sum_(it, ix) W_m[ix rt_m + it, s] Z_j[it, ix]^2   per ratio s.
// In R this was a runs x n_x n_t product with each Mx (the "x step"), kept as
// rx runs x n_t matrices, then per term rx products with Mt on the reference
// BLAS and a weighted sum of squares: most of the diagnosis with two
// candidates. Here a block of runs at a time, every term in one pass over the
// outputs: the residuals and every x step packed straight into the panels of
// the register-tiled product (tiled_product.h), each term's Z tile squared and
// weighted while in cache; no runs x n matrix is formed. Each run is computed
// the same way in the same order whichever thread takes its block, so the
// result does not depend on the threads.
#include <RcppArmadillo.h>
#include <algorithm>
#include <vector>
#include "parallel_waves.h"
#include "tiled_product.h"

namespace {

constexpr int kRows = griddy::kTileRows;
constexpr int kCols = griddy::kTileCols;

// One term: its x directions (columns first .. first + rx - 1 of Mx), Mt
// packed for tiled_product(), and its weights.
struct OtherTerm {
  int first, rx, rt, col_panels;
  griddy::AlignedBuffer b_packed;
  std::vector<double> w;  // (rx rt) x ratios, column-major
};

struct OtherWork {
  griddy::AlignedBuffer Q, Z, e;
  OtherWork(std::size_t q_size, std::size_t z_size, int block) : Q(q_size), Z(z_size), e(block) {}
};

}  // namespace

// Y: the runs' outputs, runs x (n_x n_t), library layout (x setting k's n_t
// outputs in columns k n_t .. k n_t + n_t - 1); y: the field data (complete);
// Mx: n_x x (all terms' x directions); per term m: Mts[[m]] (n_t x rt_m),
// Ws[[m]] ((rx_m rt_m) x ratios), its x directions the columns x_first[m] ..
// x_first[m] + x_count[m] - 1 (0-based) of Mx. Returns runs x (ratios x
// terms), term m's ratios in columns m * ratios ...
// [[Rcpp::export]]
Rcpp::NumericMatrix other_drops_cpp(const arma::mat& Y, const arma::vec& y, const arma::mat& Mx,
                                    const Rcpp::List& Mts, const Rcpp::List& Ws,
                                    const Rcpp::IntegerVector& x_first,
                                    const Rcpp::IntegerVector& x_count, int threads = 1) {
  const arma::uword J = Y.n_rows;
  const arma::uword n_x = Mx.n_rows, RX = Mx.n_cols;
  const int n_terms = Mts.size();
  if (n_x == 0 || Y.n_cols % n_x != 0 || y.n_elem != Y.n_cols || Ws.size() != n_terms ||
      x_first.size() != n_terms || x_count.size() != n_terms) {
    Rcpp::stop("other_drops: shapes do not fit (Y %d columns, y %d, Mx %d rows, %d terms)",
               static_cast<int>(Y.n_cols), static_cast<int>(y.n_elem), static_cast<int>(n_x),
               n_terms);
  }
  const arma::uword n_t = Y.n_cols / n_x;
  const int K = static_cast<int>(n_t);
  int n_ratio = -1;
  std::vector<OtherTerm> terms(n_terms);
  int max_panels = 0;
  for (int m = 0; m < n_terms; ++m) {
    const Rcpp::NumericMatrix Mt = Mts[m];
    const Rcpp::NumericMatrix W = Ws[m];
    OtherTerm& tm = terms[m];
    tm.first = x_first[m];
    tm.rx = x_count[m];
    tm.rt = Mt.ncol();
    if (n_ratio < 0) n_ratio = W.ncol();
    if (Mt.nrow() != K || tm.first < 0 || tm.rx < 0 ||
        static_cast<arma::uword>(tm.first + tm.rx) > RX || W.nrow() != tm.rx * tm.rt ||
        W.ncol() != n_ratio) {
      Rcpp::stop("other_drops: term %d does not fit (Mt %d x %d, W %d x %d, x directions %d..%d "
                 "of %d)", m + 1, Mt.nrow(), Mt.ncol(), W.nrow(), W.ncol(), tm.first + 1,
                 tm.first + tm.rx, static_cast<int>(RX));
    }
    // Mt packed in panels of kCols columns (zero padding), as tiled_product() reads B
    tm.col_panels = (tm.rt + kCols - 1) / kCols;
    max_panels = std::max(max_panels, tm.col_panels);
    tm.b_packed.resize(static_cast<std::size_t>(tm.col_panels) * K * kCols);
    for (int i = 0; i < tm.rt; ++i) {
      double* b = tm.b_packed.data() + static_cast<std::size_t>(i / kCols) * K * kCols + i % kCols;
      for (int k = 0; k < K; ++k) b[static_cast<std::size_t>(k) * kCols] = Mt(k, i);
    }
    tm.w.assign(W.begin(), W.end());
  }
  if (n_ratio < 0) n_ratio = 0;
  Rcpp::NumericMatrix out(J, n_ratio * n_terms);  // zero-filled: the blocks add into it
  if (J == 0 || RX == 0 || n_ratio == 0) return out;
  double* res = out.begin();
  const std::vector<double> mx(Mx.begin(), Mx.end());
  // blocks of up to 256 runs, a multiple of the tile's rows, with Q (RX n_t
  // per run) in cache: up to 2^17 doubles (1 MB)
  const int per_run = static_cast<int>(RX * n_t);
  const int block = std::max(kRows, std::min(256, ((1 << 17) / per_run) / kRows * kRows));
  const std::size_t q_size = static_cast<std::size_t>(block) * K;  // one x direction
  threads = griddy::usable_threads(threads);
  std::vector<OtherWork> work;
  work.reserve(threads);
  for (int k = 0; k < threads; ++k) {
    work.emplace_back(q_size * RX, static_cast<std::size_t>(block) * max_panels * kCols, block);
  }
  const griddy::Kernels kernels = griddy::kernels();
  const long long n_blocks = (static_cast<long long>(J) + block - 1) / block;
  const double block_cost = static_cast<double>(block) * RX * n_t * (n_x + 2.0 * K);
  const long long wave = threads * std::max(1LL, static_cast<long long>(1e10 / block_cost));
  griddy::parallel_waves(n_blocks, wave, threads, [&](long long b, int thread) {
    OtherWork& ws = work[thread];
    const arma::uword first = static_cast<arma::uword>(b) * block;
    const int rows = static_cast<int>(std::min<arma::uword>(block, J - first));
    const int row_panels = (rows + kRows - 1) / kRows;
    double* Q = ws.Q.data();
    double* Z = ws.Z.data();
    double* e = ws.e.data();
    // the x steps into Q's panels, every x direction from one read of Y:
    // q_ix[t, r] = sum_k Mx[k, ix] (y[c] - Y[first + r, c]), c = k n_t + t,
    // each column of Y read down the block (rows beyond the block's stay 0)
    std::fill(Q, Q + RX * q_size, 0.0);
    for (arma::uword k = 0; k < n_x; ++k) {
      for (arma::uword t = 0; t < n_t; ++t) {
        const double* yc = Y.colptr(k * n_t + t) + first;
        const double yk = y[k * n_t + t];
        for (int r = 0; r < rows; ++r) e[r] = yk - yc[r];
        for (arma::uword ix = 0; ix < RX; ++ix) {
          const double m = mx[ix * n_x + k];
          if (m == 0.0) continue;
          double* q = Q + ix * q_size + t * kRows;
          for (int ip = 0; ip < row_panels; ++ip) {
            const int r0 = ip * kRows;
            double* qp = q + static_cast<std::size_t>(ip) * K * kRows;
            if (r0 + kRows <= rows) {
              for (int r = 0; r < kRows; ++r) qp[r] += m * e[r0 + r];
            } else {
              for (int r = 0; r < rows - r0; ++r) qp[r] += m * e[r0 + r];
            }
          }
        }
      }
    }
    for (int mi = 0; mi < n_terms; ++mi) {
      const OtherTerm& tm = terms[mi];
      for (int ix = 0; ix < tm.rx; ++ix) {
        griddy::tiled_product(Q + (tm.first + ix) * q_size, row_panels, tm.b_packed.data(),
                              tm.col_panels, K, std::min(K, 256), Z, block, kernels.tile);
        // Z's columns squared and weighted into each ratio's drop
        for (int s = 0; s < n_ratio; ++s) {
          double* o = res + static_cast<std::size_t>(mi * n_ratio + s) * J + first;
          const double* w = tm.w.data() + static_cast<std::size_t>(s) * tm.rx * tm.rt +
            static_cast<std::size_t>(ix) * tm.rt;
          for (int it = 0; it < tm.rt; ++it) {
            const double wi = w[it];
            const double* z = Z + static_cast<std::size_t>(it) * block;
            GRIDDY_SIMD
            for (int r = 0; r < rows; ++r) o[r] += wi * z[r] * z[r];
          }
        }
      }
    }
  });
  return out;
}
