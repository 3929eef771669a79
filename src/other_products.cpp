// The runs' products of diagnose_gap()'s "other" model (R/diagnose_gap-other.R,
// kronecker_products()): for every run j, with its residual E_j = y - Y_j as
// an n_t x n_x matrix (column k the residuals at x setting k),
//   Z_j = Mt' E_j Mx            (rt x rx)
//   drop_j(s) = sum_(it, ix) W[ix rt + it, s] Z_j[it, ix]^2   for each ratio s.
// In R this is a runs x n_x n_t product with Mx (the "x step"), kept as rx
// runs x n_t matrices, then per grid point rx products with Mt on the
// reference BLAS and a weighted sum of squares: most of the diagnosis with
// two candidates. Here a block of runs at a time: the residuals and the x
// step packed straight into the panels of the register-tiled product
// (tiled_product.h), Z's tile squared and weighted while in cache; no runs x
// n matrix is formed. Each run is computed the same way in the same order whichever
// thread takes its block, so the result does not depend on the threads.
#include <RcppArmadillo.h>
#include <algorithm>
#include <vector>
#include "parallel_waves.h"
#include "tiled_product.h"

namespace {

constexpr int kRows = griddy::kTileRows;
constexpr int kCols = griddy::kTileCols;

struct OtherWork {
  griddy::AlignedBuffer Q, Z, e;
  OtherWork(int n_t, int block, int col_panels, int rx)
      : Q(static_cast<std::size_t>(n_t) * block * rx),
        Z(static_cast<std::size_t>(block) * col_panels * kCols), e(block) {}
};

}  // namespace

// Y: the runs' outputs, runs x (n_x n_t), library layout (x setting k's n_t
// outputs in columns k n_t .. k n_t + n_t - 1); y: the field data (complete);
// Mx: n_x x rx; Mt: n_t x rt; W: (rx rt) x ratios. Returns runs x ratios.
// [[Rcpp::export]]
Rcpp::NumericMatrix other_drops_cpp(const arma::mat& Y, const arma::vec& y, const arma::mat& Mx,
                                    const arma::mat& Mt, const arma::mat& W,
                                    int threads = 1) {
  const arma::uword J = Y.n_rows;
  const arma::uword n_x = Mx.n_rows, rx = Mx.n_cols;
  const arma::uword n_t = Mt.n_rows, rt = Mt.n_cols;
  const arma::uword n_ratio = W.n_cols;
  if (Y.n_cols != n_x * n_t || y.n_elem != Y.n_cols || W.n_rows != rx * rt) {
    Rcpp::stop("other_drops: shapes do not fit (Y %d columns, y %d, Mx %d x %d, Mt %d x %d, "
               "W %d rows)", static_cast<int>(Y.n_cols), static_cast<int>(y.n_elem), static_cast<int>(n_x), static_cast<int>(rx),
               static_cast<int>(n_t), static_cast<int>(rt), static_cast<int>(W.n_rows));
  }
  Rcpp::NumericMatrix out(J, n_ratio);  // zero-filled: the blocks add into it
  if (J == 0 || rx == 0 || rt == 0 || n_ratio == 0) return out;
  double* res = out.begin();
  const std::vector<double> mx(Mx.begin(), Mx.end()), w_all(W.begin(), W.end());
  const int K = static_cast<int>(n_t);
  const int col_panels = static_cast<int>((rt + kCols - 1) / kCols);
  // Mt packed in panels of kCols columns (zero padding), as tiled_product() reads B
  griddy::AlignedBuffer b_packed(static_cast<std::size_t>(col_panels) * K * kCols);
  for (arma::uword i = 0; i < rt; ++i) {
    double* b = b_packed.data() + (i / kCols) * K * kCols + i % kCols;
    for (int k = 0; k < K; ++k) b[static_cast<std::size_t>(k) * kCols] = Mt(k, i);
  }
  // blocks of up to 256 runs, a multiple of the tile's rows, with Q (rx n_t
  // per run) in cache: up to 2^17 doubles (1 MB)
  const int per_run = static_cast<int>(rx * n_t);
  const int block = std::max(kRows, std::min(256, ((1 << 17) / per_run) / kRows * kRows));
  threads = griddy::usable_threads(threads);
  std::vector<OtherWork> work;
  work.reserve(threads);
  for (int k = 0; k < threads; ++k) work.emplace_back(K, block, col_panels, static_cast<int>(rx));
  const griddy::Kernels kernels = griddy::kernels();
  const long long n_blocks = (static_cast<long long>(J) + block - 1) / block;
  const double block_cost = static_cast<double>(block) * rx * n_t * (n_x + 2.0 * rt);
  const long long wave = threads * std::max(1LL, static_cast<long long>(1e10 / block_cost));
  griddy::parallel_waves(n_blocks, wave, threads, [&](long long b, int thread) {
    OtherWork& ws = work[thread];
    const arma::uword first = static_cast<arma::uword>(b) * block;
    const int rows = static_cast<int>(std::min<arma::uword>(block, J - first));
    const int row_panels = (rows + kRows - 1) / kRows;
    double* Q = ws.Q.data();
    double* Z = ws.Z.data();
    // the x step into Q's panels, every x direction from one read of Y:
    // q_ix[t, r] = sum_k Mx[k, ix] (y[c] - Y[first + r, c]), c = k n_t + t,
    // each column of Y read down the block (rows beyond the block's stay 0)
    const std::size_t q_size = static_cast<std::size_t>(row_panels) * K * kRows;
    std::fill(Q, Q + rx * q_size, 0.0);
    for (arma::uword k = 0; k < n_x; ++k) {
      for (arma::uword t = 0; t < n_t; ++t) {
        const double* yc = Y.colptr(k * n_t + t) + first;
        const double yk = y[k * n_t + t];
        double* e = ws.e.data();
        for (int r = 0; r < rows; ++r) e[r] = yk - yc[r];
        for (arma::uword ix = 0; ix < rx; ++ix) {
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
    for (arma::uword ix = 0; ix < rx; ++ix) {
      griddy::tiled_product(Q + ix * q_size, row_panels, b_packed.data(), col_panels, K,
                            std::min(K, 256), Z, block, kernels.tile);
      // Z's columns squared and weighted into each ratio's drop
      for (arma::uword s = 0; s < n_ratio; ++s) {
        double* o = res + s * J + first;
        for (arma::uword it = 0; it < rt; ++it) {
          const double w = w_all[s * rx * rt + ix * rt + it];
          const double* z = Z + it * block;
          GRIDDY_SIMD
          for (int r = 0; r < rows; ++r) o[r] += w * z[r] * z[r];
        }
      }
    }
  });
  return out;
}
