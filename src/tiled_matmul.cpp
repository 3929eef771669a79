// A general matrix product X B on the package's tiled kernels
// (tiled_product.h): the discrepancy's products of every run's whitened
// residuals with the kernels' basis and rotations (R/discrepancy-engine.R),
// which R's reference BLAS runs several times slower. Rows of X are cut into
// blocks of kBlockRows, one block per work item on `threads` threads; each
// entry is summed in the same order whatever the threads.
#include <Rcpp.h>
#include <algorithm>
#include <vector>
#include "parallel_waves.h"
#include "tiled_product.h"

namespace {

constexpr int kRows = griddy::kTileRows;
constexpr int kCols = griddy::kTileCols;
constexpr int kBlockRows = 16 * kRows;  // runs per work item
constexpr int kPass = 256;              // depth per pass: a panel of B stays in L1

}  // namespace

// X %*% B for X (N x K) and B (K x M).
// [[Rcpp::export]]
Rcpp::NumericMatrix tiled_matmul_cpp(const Rcpp::NumericMatrix& X, const Rcpp::NumericMatrix& B,
                                     int threads) {
  const int N = X.nrow(), K = X.ncol(), M = B.ncol();
  if (B.nrow() != K) Rcpp::stop("tiled_matmul: non-conformable matrices.");
  Rcpp::NumericMatrix out(N, M);
  if (N == 0 || M == 0 || K == 0) return out;
  const griddy::Kernels kern = griddy::kernels();
  const int col_panels = (M + kCols - 1) / kCols;
  griddy::AlignedBuffer b_packed(static_cast<std::size_t>(col_panels) * K * kCols);
  for (int jp = 0; jp < col_panels; ++jp) {
    double* b = b_packed.data() + static_cast<std::size_t>(jp) * K * kCols;
    for (int k = 0; k < K; ++k) {
      for (int j = 0; j < kCols; ++j) {
        const int col = jp * kCols + j;
        b[k * kCols + j] = col < M ? B(k, col) : 0.0;
      }
    }
  }
  const int n_blocks = (N + kBlockRows - 1) / kBlockRows;
  const int n_threads = griddy::usable_threads(threads);
  std::vector<griddy::AlignedBuffer> q(n_threads), c(n_threads);
  for (int i = 0; i < n_threads; ++i) {
    q[i].resize(static_cast<std::size_t>(K) * kBlockRows);
    c[i].resize(static_cast<std::size_t>(kBlockRows) * col_panels * kCols);
  }
  const double* x = X.begin();
  double* o = out.begin();
  griddy::parallel_waves(n_blocks, 64LL * n_threads, n_threads, [&](long long item, int thread) {
    const int first = static_cast<int>(item) * kBlockRows;
    const int rows = std::min(kBlockRows, N - first);
    const int row_panels = (rows + kRows - 1) / kRows;
    double* qp = q[thread].data();
    for (int ip = 0; ip < row_panels; ++ip) {
      double* qq = qp + static_cast<std::size_t>(ip) * K * kRows;
      for (int k = 0; k < K; ++k) {
        const double* xk = x + static_cast<std::size_t>(k) * N + first + ip * kRows;
        for (int r = 0; r < kRows; ++r) {
          qq[k * kRows + r] = ip * kRows + r < rows ? xk[r] : 0.0;
        }
      }
    }
    double* cp = c[thread].data();
    griddy::tiled_product(qp, row_panels, b_packed.data(), col_panels, K, kPass, cp, kBlockRows,
                          kern.tile);
    for (int j = 0; j < M; ++j) {
      std::copy(cp + static_cast<std::size_t>(j) * kBlockRows,
                cp + static_cast<std::size_t>(j) * kBlockRows + rows,
                o + static_cast<std::size_t>(j) * N + first);
    }
  });
  return out;
}
