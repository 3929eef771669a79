// The two matrix products of the quadratic forms (src/quadratic_forms.cpp),
// blocked and register-tiled by hand so that they run near the processor's
// floating-point limit without an optimised BLAS (R's reference BLAS is
// several times slower), and without compiler flags: the AVX2/FMA tiles are
// chosen at run time where the processor has them (kernels()).
//
// * tiled_product(): C = Q B. Layout as in BLIS/GotoBLAS: Q (m x K) packed in
//   panels of kTileRows rows, each K x kTileRows with the rows contiguous;
//   B (K x n) in panels of kTileCols columns, each K x kTileCols.
// * whitened_sums(): c_r = |e_r' L|^2 for rows e_r of E (m x n, packed as Q)
//   and a lower-triangular L (n x n), packed by lower_panels(): panel jp holds
//   columns 6 jp .. 6 jp + 5 over rows 6 jp .. n - 1 (the rest are zero).
//
// Each entry is accumulated in a fixed order, in passes of fixed depth, so
// it is the same sum however the rows are split between threads.
#ifndef GRIDDY_TILED_PRODUCT_H
#define GRIDDY_TILED_PRODUCT_H

#include <cstddef>
#include <vector>

namespace griddy {

constexpr int kTileRows = 8;  // rows (library runs) per tile: two AVX2 vectors
constexpr int kTileCols = 6;  // columns per tile: broadcasts

// The tile C (kTileRows x kTileCols, column stride ldc) = (or +=, `add`)
// sum over k < depth of q[k, ] b[k, ]', q and b packed panels.
using TileKernel = void (*)(int depth, const double* q, const double* b, double* c,
                            std::ptrdiff_t ldc, bool add);

// out[r] = (or +=, `add`) the sum over the tile's columns j of
// (sum over k < depth of q[k, r] b[k, j])^2, for the kTileRows rows r.
using SquareKernel = void (*)(int depth, const double* q, const double* b, double* out,
                              bool add);

struct Kernels {
  TileKernel tile;
  SquareKernel square;
};

// The fastest kernels for this processor, chosen once; `portable = true`
// gives the plain C++ ones (for tests).
Kernels kernels(bool portable = false);

// Whether kernels() uses the AVX2/FMA tiles.
bool kernels_use_avx2();

// Memory aligned for vector loads (64 bytes), zero-filled.
class AlignedBuffer {
 public:
  explicit AlignedBuffer(std::size_t n = 0) { resize(n); }
  // a move keeps the storage (and so the aligned pointer into it); a copy
  // would not
  AlignedBuffer(const AlignedBuffer&) = delete;
  AlignedBuffer& operator=(const AlignedBuffer&) = delete;
  AlignedBuffer(AlignedBuffer&&) = default;
  AlignedBuffer& operator=(AlignedBuffer&&) = default;
  void resize(std::size_t n);
  double* data() { return ptr_; }
  const double* data() const { return ptr_; }

 private:
  std::vector<double> store_;
  double* ptr_ = nullptr;
};

// C (row_panels * kTileRows x col_panels * kTileCols, column-major with
// leading dimension ldc) = Q B, with Q and B packed as above over K, in
// passes of `pass` entries of K (each pass's sums added to C in turn).
void tiled_product(const double* q_packed, int row_panels, const double* b_packed,
                   int col_panels, int K, int pass, double* c, std::ptrdiff_t ldc,
                   TileKernel kernel);

// The doubles lower_panels() writes for an n x n factor.
std::size_t lower_panels_size(int n);

// Packs the lower triangle of L (n x n, column-major) for whitened_sums().
void lower_panels(const double* L, int n, double* b);

// out[r] = |e_r' L|^2 for the row_panels * kTileRows rows of E (packed as
// Q, over n) and L packed by lower_panels().
void whitened_sums(const double* e_packed, int row_panels, int n, const double* b_packed,
                   double* out, SquareKernel kernel);

}  // namespace griddy

#endif
