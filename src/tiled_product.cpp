// The blocked, register-tiled product of tiled_product.h.
#include "tiled_product.h"

#include <algorithm>
#include <cstdint>

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#define GRIDDY_X86_DISPATCH 1
#include <immintrin.h>
#endif

namespace griddy {

void AlignedBuffer::resize(std::size_t n) {
  store_.assign(n + 8, 0.0);
  const std::uintptr_t at = reinterpret_cast<std::uintptr_t>(store_.data());
  ptr_ = store_.data() + ((64 - at % 64) % 64) / sizeof(double);
}

namespace {

// Plain C++: any processor, any compiler.
void tile_portable(int depth, const double* q, const double* b, double* c,
                   std::ptrdiff_t ldc, bool add) {
  double acc[kTileCols][kTileRows];
  for (int j = 0; j < kTileCols; ++j) {
    for (int r = 0; r < kTileRows; ++r) acc[j][r] = add ? c[j * ldc + r] : 0.0;
  }
  for (int k = 0; k < depth; ++k) {
    for (int j = 0; j < kTileCols; ++j) {
      const double bk = b[j];
      for (int r = 0; r < kTileRows; ++r) acc[j][r] += q[r] * bk;
    }
    q += kTileRows;
    b += kTileCols;
  }
  for (int j = 0; j < kTileCols; ++j) {
    for (int r = 0; r < kTileRows; ++r) c[j * ldc + r] = acc[j][r];
  }
}

#ifdef GRIDDY_X86_DISPATCH
// AVX2 with fused multiply-add: 12 accumulators of 4 doubles (8 runs x 6 grid
// points) stay in registers over the whole depth; each step loads 8 entries
// of q, broadcasts 6 of b and does 12 FMAs. Compiled for AVX2 whatever the
// package's flags, and only called when the processor has it.
__attribute__((target("avx2,fma")))
void tile_avx2(int depth, const double* q, const double* b, double* c, std::ptrdiff_t ldc,
               bool add) {
  __m256d c0a, c0b, c1a, c1b, c2a, c2b, c3a, c3b, c4a, c4b, c5a, c5b;
  if (add) {
    c0a = _mm256_loadu_pd(c);            c0b = _mm256_loadu_pd(c + 4);
    c1a = _mm256_loadu_pd(c + ldc);      c1b = _mm256_loadu_pd(c + ldc + 4);
    c2a = _mm256_loadu_pd(c + 2 * ldc);  c2b = _mm256_loadu_pd(c + 2 * ldc + 4);
    c3a = _mm256_loadu_pd(c + 3 * ldc);  c3b = _mm256_loadu_pd(c + 3 * ldc + 4);
    c4a = _mm256_loadu_pd(c + 4 * ldc);  c4b = _mm256_loadu_pd(c + 4 * ldc + 4);
    c5a = _mm256_loadu_pd(c + 5 * ldc);  c5b = _mm256_loadu_pd(c + 5 * ldc + 4);
  } else {
    c0a = c0b = c1a = c1b = c2a = c2b = _mm256_setzero_pd();
    c3a = c3b = c4a = c4b = c5a = c5b = _mm256_setzero_pd();
  }
  for (int k = 0; k < depth; ++k) {
    const __m256d qa = _mm256_loadu_pd(q);
    const __m256d qb = _mm256_loadu_pd(q + 4);
    __m256d bk = _mm256_broadcast_sd(b);
    c0a = _mm256_fmadd_pd(qa, bk, c0a);  c0b = _mm256_fmadd_pd(qb, bk, c0b);
    bk = _mm256_broadcast_sd(b + 1);
    c1a = _mm256_fmadd_pd(qa, bk, c1a);  c1b = _mm256_fmadd_pd(qb, bk, c1b);
    bk = _mm256_broadcast_sd(b + 2);
    c2a = _mm256_fmadd_pd(qa, bk, c2a);  c2b = _mm256_fmadd_pd(qb, bk, c2b);
    bk = _mm256_broadcast_sd(b + 3);
    c3a = _mm256_fmadd_pd(qa, bk, c3a);  c3b = _mm256_fmadd_pd(qb, bk, c3b);
    bk = _mm256_broadcast_sd(b + 4);
    c4a = _mm256_fmadd_pd(qa, bk, c4a);  c4b = _mm256_fmadd_pd(qb, bk, c4b);
    bk = _mm256_broadcast_sd(b + 5);
    c5a = _mm256_fmadd_pd(qa, bk, c5a);  c5b = _mm256_fmadd_pd(qb, bk, c5b);
    q += kTileRows;
    b += kTileCols;
  }
  _mm256_storeu_pd(c, c0a);            _mm256_storeu_pd(c + 4, c0b);
  _mm256_storeu_pd(c + ldc, c1a);      _mm256_storeu_pd(c + ldc + 4, c1b);
  _mm256_storeu_pd(c + 2 * ldc, c2a);  _mm256_storeu_pd(c + 2 * ldc + 4, c2b);
  _mm256_storeu_pd(c + 3 * ldc, c3a);  _mm256_storeu_pd(c + 3 * ldc + 4, c3b);
  _mm256_storeu_pd(c + 4 * ldc, c4a);  _mm256_storeu_pd(c + 4 * ldc + 4, c4b);
  _mm256_storeu_pd(c + 5 * ldc, c5a);  _mm256_storeu_pd(c + 5 * ldc + 4, c5b);
}

bool cpu_has_avx2_fma() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}
#endif

}  // namespace

bool tile_kernel_is_avx2() {
#ifdef GRIDDY_X86_DISPATCH
  static const bool avx2 = cpu_has_avx2_fma();
  return avx2;
#else
  return false;
#endif
}

TileKernel tile_kernel(bool portable) {
#ifdef GRIDDY_X86_DISPATCH
  if (!portable && tile_kernel_is_avx2()) return tile_avx2;
#endif
  return tile_portable;
}

// Loop order of BLIS: a block of kDepth entries of K at a time, then each
// panel of B (kDepth x kTileCols, held in L1 while every panel of Q passes
// it), then each panel of Q (kDepth x kTileRows, from L2).
void tiled_product(const double* q_packed, int row_panels, const double* b_packed,
                   int col_panels, int K, double* c, std::ptrdiff_t ldc, TileKernel kernel) {
  for (int p0 = 0; p0 < K; p0 += kDepth) {
    const int depth = std::min(kDepth, K - p0);
    for (int jp = 0; jp < col_panels; ++jp) {
      const double* b = b_packed + (static_cast<std::ptrdiff_t>(jp) * K + p0) * kTileCols;
      double* c_panel = c + static_cast<std::ptrdiff_t>(jp) * kTileCols * ldc;
      for (int ip = 0; ip < row_panels; ++ip) {
        const double* q = q_packed + (static_cast<std::ptrdiff_t>(ip) * K + p0) * kTileRows;
        kernel(depth, q, b, c_panel + ip * kTileRows, ldc, p0 > 0);
      }
    }
  }
}

}  // namespace griddy
