// A matrix product C = Q B for the quadratic forms (src/quadratic_forms.cpp),
// blocked and register-tiled by hand so that it runs near the processor's
// floating-point limit without an optimised BLAS (R's reference BLAS is
// several times slower), and without compiler flags: the AVX2/FMA tile is
// chosen at run time where the processor has it (tile_kernel()).
//
// Layout (as in BLIS/GotoBLAS): Q (m x K) is packed in panels of kTileRows
// rows, each panel K x kTileRows with the rows contiguous; B (K x n) in panels
// of kTileCols columns, each K x kTileCols. A tile of C (kTileRows x
// kTileCols) is accumulated over K in blocks of kDepth in a fixed order, so
// every entry of C is the same sum, in the same order, however the rows are
// split between threads.
#ifndef GRIDDY_TILED_PRODUCT_H
#define GRIDDY_TILED_PRODUCT_H

#include <cstddef>
#include <vector>

namespace griddy {

constexpr int kTileRows = 8;   // rows of Q (library runs) per tile: two AVX2 vectors
constexpr int kTileCols = 6;   // columns of B (grid points) per tile: broadcasts
constexpr int kDepth = 256;    // entries of K per pass over a tile (fits L1)

// The tile C (kTileRows x kTileCols, column stride ldc) = (or +=, `add`)
// sum over k < depth of q[k, ] b[k, ]', q and b packed panels.
using TileKernel = void (*)(int depth, const double* q, const double* b, double* c,
                            std::ptrdiff_t ldc, bool add);

// The fastest tile kernel for this processor, chosen once; `portable = true`
// gives the plain C++ one (for tests).
TileKernel tile_kernel(bool portable = false);

// Whether tile_kernel() uses the AVX2/FMA tile.
bool tile_kernel_is_avx2();

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
// leading dimension ldc) = Q B, with Q and B packed as above over K.
void tiled_product(const double* q_packed, int row_panels, const double* b_packed,
                   int col_panels, int K, double* c, std::ptrdiff_t ldc, TileKernel kernel);

}  // namespace griddy

#endif
