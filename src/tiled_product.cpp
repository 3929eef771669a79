// The blocked, register-tiled products of tiled_product.h.
#include "tiled_product.h"

#include <algorithm>
#include <cstdint>

// GRIDDY_PORTABLE_ONLY builds what a non-x86 processor gets (the plain C++
// kernels alone), so that build can be tested on x86 too
// (tools/check-portable-build.sh).
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__)) && \
    !defined(GRIDDY_PORTABLE_ONLY)
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

// ---- plain C++: any processor, any compiler --------------------------------

// acc[j][r] = sum over k < depth of q[k, r] b[k, j]
void accumulate_portable(int depth, const double* q, const double* b,
                         double acc[kTileCols][kTileRows]) {
  for (int j = 0; j < kTileCols; ++j) {
    for (int r = 0; r < kTileRows; ++r) acc[j][r] = 0.0;
  }
  for (int k = 0; k < depth; ++k) {
    for (int j = 0; j < kTileCols; ++j) {
      const double bk = b[j];
      for (int r = 0; r < kTileRows; ++r) acc[j][r] += q[r] * bk;
    }
    q += kTileRows;
    b += kTileCols;
  }
}

void tile_portable(int depth, const double* q, const double* b, double* c,
                   std::ptrdiff_t ldc, bool add) {
  double acc[kTileCols][kTileRows];
  accumulate_portable(depth, q, b, acc);
  for (int j = 0; j < kTileCols; ++j) {
    for (int r = 0; r < kTileRows; ++r) c[j * ldc + r] = (add ? c[j * ldc + r] : 0.0) + acc[j][r];
  }
}

void square_portable(int depth, const double* q, const double* b, double* out, bool add) {
  double acc[kTileCols][kTileRows];
  accumulate_portable(depth, q, b, acc);
  for (int r = 0; r < kTileRows; ++r) {
    double s = acc[0][r] * acc[0][r];
    for (int j = 1; j < kTileCols; ++j) s += acc[j][r] * acc[j][r];
    out[r] = add ? out[r] + s : s;
  }
}

#ifdef GRIDDY_X86_DISPATCH
// ---- AVX2 with fused multiply-add ---------------------------------------------
// 12 accumulators of 4 doubles (8 rows x 6 columns) stay in registers over
// the whole depth; each step loads 8 entries of q, broadcasts 6 of b and does
// 12 FMAs. Compiled for AVX2 whatever the package's flags, and called only
// when the processor has it. (A macro, so that both kernels keep the
// accumulators in registers.)
#define GRIDDY_AVX2_ACCUMULATE(depth, q, b)                                   \
  __m256d c0a = _mm256_setzero_pd(), c0b = c0a, c1a = c0a, c1b = c0a,         \
          c2a = c0a, c2b = c0a, c3a = c0a, c3b = c0a, c4a = c0a, c4b = c0a,   \
          c5a = c0a, c5b = c0a;                                               \
  for (int k = 0; k < (depth); ++k) {                                         \
    const __m256d qa = _mm256_loadu_pd(q);                                    \
    const __m256d qb = _mm256_loadu_pd((q) + 4);                              \
    __m256d bk = _mm256_broadcast_sd(b);                                      \
    c0a = _mm256_fmadd_pd(qa, bk, c0a);  c0b = _mm256_fmadd_pd(qb, bk, c0b);  \
    bk = _mm256_broadcast_sd((b) + 1);                                        \
    c1a = _mm256_fmadd_pd(qa, bk, c1a);  c1b = _mm256_fmadd_pd(qb, bk, c1b);  \
    bk = _mm256_broadcast_sd((b) + 2);                                        \
    c2a = _mm256_fmadd_pd(qa, bk, c2a);  c2b = _mm256_fmadd_pd(qb, bk, c2b);  \
    bk = _mm256_broadcast_sd((b) + 3);                                        \
    c3a = _mm256_fmadd_pd(qa, bk, c3a);  c3b = _mm256_fmadd_pd(qb, bk, c3b);  \
    bk = _mm256_broadcast_sd((b) + 4);                                        \
    c4a = _mm256_fmadd_pd(qa, bk, c4a);  c4b = _mm256_fmadd_pd(qb, bk, c4b);  \
    bk = _mm256_broadcast_sd((b) + 5);                                        \
    c5a = _mm256_fmadd_pd(qa, bk, c5a);  c5b = _mm256_fmadd_pd(qb, bk, c5b);  \
    (q) += kTileRows;                                                         \
    (b) += kTileCols;                                                         \
  }

__attribute__((target("avx2,fma")))
void tile_avx2(int depth, const double* q, const double* b, double* c, std::ptrdiff_t ldc,
               bool add) {
  GRIDDY_AVX2_ACCUMULATE(depth, q, b)
  const __m256d acc[2 * kTileCols] = {c0a, c0b, c1a, c1b, c2a, c2b,
                                      c3a, c3b, c4a, c4b, c5a, c5b};
  for (int j = 0; j < kTileCols; ++j) {
    for (int h = 0; h < 2; ++h) {
      double* at = c + j * ldc + 4 * h;
      const __m256d v = add ? _mm256_add_pd(_mm256_loadu_pd(at), acc[2 * j + h])
                            : acc[2 * j + h];
      _mm256_storeu_pd(at, v);
    }
  }
}

__attribute__((target("avx2,fma")))
void square_avx2(int depth, const double* q, const double* b, double* out, bool add) {
  GRIDDY_AVX2_ACCUMULATE(depth, q, b)
  __m256d sa = _mm256_mul_pd(c0a, c0a), sb = _mm256_mul_pd(c0b, c0b);
  sa = _mm256_fmadd_pd(c1a, c1a, sa);  sb = _mm256_fmadd_pd(c1b, c1b, sb);
  sa = _mm256_fmadd_pd(c2a, c2a, sa);  sb = _mm256_fmadd_pd(c2b, c2b, sb);
  sa = _mm256_fmadd_pd(c3a, c3a, sa);  sb = _mm256_fmadd_pd(c3b, c3b, sb);
  sa = _mm256_fmadd_pd(c4a, c4a, sa);  sb = _mm256_fmadd_pd(c4b, c4b, sb);
  sa = _mm256_fmadd_pd(c5a, c5a, sa);  sb = _mm256_fmadd_pd(c5b, c5b, sb);
  if (add) {
    sa = _mm256_add_pd(_mm256_loadu_pd(out), sa);
    sb = _mm256_add_pd(_mm256_loadu_pd(out + 4), sb);
  }
  _mm256_storeu_pd(out, sa);
  _mm256_storeu_pd(out + 4, sb);
}
#undef GRIDDY_AVX2_ACCUMULATE

bool cpu_has_avx2_fma() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}
#endif

}  // namespace

bool kernels_use_avx2() {
#ifdef GRIDDY_X86_DISPATCH
  static const bool avx2 = cpu_has_avx2_fma();
  return avx2;
#else
  return false;
#endif
}

Kernels kernels(bool portable) {
#ifdef GRIDDY_X86_DISPATCH
  if (!portable && kernels_use_avx2()) return Kernels{tile_avx2, square_avx2};
#endif
  return Kernels{tile_portable, square_portable};
}

// Loop order of BLIS: a pass of K at a time, then each panel of B (pass x
// kTileCols, held in L1 while every panel of Q goes by), then each panel of
// Q (pass x kTileRows, from L2).
void tiled_product(const double* q_packed, int row_panels, const double* b_packed,
                   int col_panels, int K, int pass, double* c, std::ptrdiff_t ldc,
                   TileKernel kernel) {
  for (int p0 = 0; p0 < K; p0 += pass) {
    const int depth = std::min(pass, K - p0);
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

std::size_t lower_panels_size(int n) {
  std::size_t size = 0;
  for (int j0 = 0; j0 < n; j0 += kTileCols) size += static_cast<std::size_t>(n - j0) * kTileCols;
  return size;
}

void lower_panels(const double* L, int n, double* b) {
  for (int j0 = 0; j0 < n; j0 += kTileCols) {
    for (int k = j0; k < n; ++k, b += kTileCols) {
      for (int j = 0; j < kTileCols; ++j) {
        b[j] = (j0 + j < n && k >= j0 + j) ? L[k + static_cast<std::ptrdiff_t>(j0 + j) * n] : 0.0;
      }
    }
  }
}

// Each panel of rows takes L's panels in turn (L, a few kB, stays in L1);
// a panel of L starting at column j0 needs the rows' entries from j0 on.
void whitened_sums(const double* e_packed, int row_panels, int n, const double* b_packed,
                   double* out, SquareKernel kernel) {
  for (int ip = 0; ip < row_panels; ++ip) {
    const double* e = e_packed + static_cast<std::ptrdiff_t>(ip) * n * kTileRows;
    const double* b = b_packed;
    for (int j0 = 0; j0 < n; j0 += kTileCols) {
      kernel(n - j0, e + static_cast<std::ptrdiff_t>(j0) * kTileRows, b, out + ip * kTileRows,
             j0 > 0);
      b += static_cast<std::ptrdiff_t>(n - j0) * kTileCols;
    }
  }
}

}  // namespace griddy
