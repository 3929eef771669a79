// C_ig = (y - g_i)' R_g^{-1} (y - g_i) for every library run i and correlation
// grid point g, with R_g = kron(R_x, R_t) (thesis Appendix B). The n x n matrix is
// never formed: R_t is the correlation of an AR(1)/Ornstein-Uhlenbeck process,
// whose inverse factors into a bidiagonal "innovation" transform W = L_t^{-1} E
// (grid_posterior.h), and then C = trace(R_x^{-1} W'W).
//
// R_x^{-1} = I (rho_x = 0, or n_x = 1) needs only the sum of squared
// innovations. For the other x grid points, C over the whole x grid is a
// matrix product (tiled_product.h), at the processor's floating-point limit:
// * one output per x setting (n_t = 1): W is a row e', and with the lower
//   Cholesky factor R_x^{-1} = L L', C = |e' L|^2 (whitened_sums()):
//   n_x (n_x + 1) / 2 multiply-adds per run and grid point;
// * several (n_t > 1): each run's M = W'W (n_x x n_x, one row of Q) times
//   every R_x^{-1} (a column of B): C = Q B (tiled_product()), n_x^2 per run
//   and grid point, once M is formed. The sum runs over whole columns of M
//   (passes of n_x), as trace(R_x^{-1} M) always has: a column's terms,
//   large for a near-singular R_x, cancel within it. (The upper triangle
//   alone, with off-diagonal terms doubled, would halve the work, but its
//   partial sums do not cancel: 2 to 10 times the rounding error when
//   cond(R_x) is 1e10.)
// Against the exact forms of the rounded inputs, at cond(R_x) = 2e10
// (test-engine.R), |e' L|^2 is off by 1.8e-10 at worst where the
// full trace is off by 8.7e-10, and whole columns of W'W by what the full
// trace is (1.2e-10).
//
// Runs are processed in blocks (fixed sizes, independent of the thread count)
// on `threads` OpenMP threads; every C_ig is computed the same way, in the
// same order, whichever thread does it, so C does not depend on the number of
// threads. Nothing in a parallel region calls R.
#include <RcppArmadillo.h>
#include <algorithm>
#include <vector>
#include "grid_posterior.h"
#include "parallel_waves.h"
#include "tiled_product.h"

namespace {

// The shapes quad_forms_cpp() is handed must fit together: an edited library
// or a chunk of the wrong size is an R error here, never a read past a row.
void check_quad_form_inputs(const arma::mat& Y, const arma::vec& y_field,
                            const arma::cube& Rx_inv, const arma::mat& phi) {
  const arma::uword n = y_field.n_elem;
  const arma::uword n_x = Rx_inv.n_rows;
  if (n == 0 || n_x == 0 || Rx_inv.n_cols != n_x || n % n_x != 0) {
    Rcpp::stop("quad_forms: %d field values do not split into %d x settings",
               static_cast<int>(n), static_cast<int>(n_x));
  }
  if (Y.n_cols != n) {
    Rcpp::stop("quad_forms: the outputs have %d columns but the field data %d values",
               static_cast<int>(Y.n_cols), static_cast<int>(n));
  }
  if (phi.n_rows + 1 != n / n_x) {
    Rcpp::stop("quad_forms: %d AR(1) lag coefficients for %d outputs per x setting",
               static_cast<int>(phi.n_rows), static_cast<int>(n / n_x));
  }
  if (!y_field.is_finite()) Rcpp::stop("quad_forms: the field data hold NA, NaN or Inf");
}

constexpr int kRows = griddy::kTileRows;
constexpr int kCols = griddy::kTileCols;

// What every block of runs shares: the shapes, which x grid points are the
// identity, and B: the other grid points' R_x^{-1} packed for
// tiled_product(), or their factors L packed for whitened_sums().
struct Plan {
  arma::uword n_runs, n, n_x, n_t, G_x, G_t;
  std::vector<arma::uword> identity;  // x grid points with R_x^{-1} = I
  std::vector<arma::uword> dense;     // the others
  bool whiten;                        // n_t = 1: C = |e' L|^2
  int K;                              // entries of a run's row of Q: n_x or n_x^2
  int col_panels;                     // of B in tiled_product()
  std::size_t factor_size;            // of one packed L in whitened_sums()
  griddy::AlignedBuffer b_packed;
  arma::mat phi, inv_sd;
  int block;                          // runs per block, a multiple of kRows
};

// B for tiled_product(): each grid point's R_x^{-1}, column by column.
void pack_inverses(const arma::cube& Rx_inv, Plan& p) {
  p.col_panels = static_cast<int>((p.dense.size() + kCols - 1) / kCols);
  p.b_packed.resize(static_cast<std::size_t>(p.col_panels) * p.K * kCols);
  for (std::size_t d = 0; d < p.dense.size(); ++d) {
    const double* R = Rx_inv.slice(p.dense[d]).memptr();
    double* b = p.b_packed.data() + (d / kCols) * p.K * kCols + d % kCols;
    for (int k = 0; k < p.K; ++k) b[static_cast<std::size_t>(k) * kCols] = R[k];
  }
}

// The factors L (R_x^{-1} = L L') for whitened_sums(); false when some
// R_x^{-1} has no Cholesky factor in double precision.
bool pack_factors(const arma::cube& Rx_inv, Plan& p) {
  const int n_x = static_cast<int>(p.n_x);
  p.factor_size = griddy::lower_panels_size(n_x);
  p.b_packed.resize(p.factor_size * p.dense.size());
  arma::mat L;
  for (std::size_t d = 0; d < p.dense.size(); ++d) {
    if (!arma::chol(L, Rx_inv.slice(p.dense[d]), "lower")) return false;
    griddy::lower_panels(L.memptr(), n_x, p.b_packed.data() + d * p.factor_size);
  }
  return true;
}

Plan make_plan(const arma::mat& Y, const arma::cube& Rx_inv, const arma::mat& phi) {
  Plan p;
  p.n_runs = Y.n_rows;
  p.n = Y.n_cols;
  p.n_x = Rx_inv.n_rows;
  p.n_t = p.n / p.n_x;
  p.G_x = Rx_inv.n_slices;
  p.G_t = phi.n_cols;
  p.phi = phi;
  p.inv_sd = 1.0 / arma::sqrt(1.0 - arma::square(phi));
  for (arma::uword gx = 0; gx < p.G_x; ++gx) {
    const bool eye = arma::approx_equal(Rx_inv.slice(gx), arma::eye(p.n_x, p.n_x),
                                        "absdiff", 0.0);
    (eye ? p.identity : p.dense).push_back(gx);
  }
  p.col_panels = 0;
  p.factor_size = 0;
  p.whiten = p.n_t == 1 && !p.dense.empty();
  if (p.whiten) {
    p.K = static_cast<int>(p.n_x);
    p.whiten = pack_factors(Rx_inv, p);
  }
  if (!p.whiten && !p.dense.empty()) {
    p.K = static_cast<int>(p.n_x * p.n_x);
    pack_inverses(Rx_inv, p);
  }
  // A block's residuals (and, with a product, its Q) stay in cache: up to
  // 2^19 doubles (4 MB), at most 256 runs (512 without a product). Larger
  // blocks read B fewer times; 128 to 512 runs time the same on the
  // thesis's case (54 x settings, 1,000 x grid points).
  const int per_run = static_cast<int>(p.n) + (p.dense.empty() ? 0 : p.K);
  const int cap = p.dense.empty() ? 512 : 256;
  p.block = std::max(kRows, std::min(cap, ((1 << 19) / std::max(per_run, 1)) / kRows * kRows));
  return p;
}

// One thread's buffers, allocated before the parallel region.
struct Workspace {
  griddy::AlignedBuffer W, sum_sq, Q, C_tile;
  bool finite = true;
  explicit Workspace(const Plan& p)
      : W(p.dense.empty() ? 0 : p.n * p.block), sum_sq(p.block),
        Q(p.dense.empty() ? 0 : static_cast<std::size_t>(p.K) * p.block),
        C_tile(static_cast<std::size_t>(p.block) *
               (p.whiten ? p.dense.size() : static_cast<std::size_t>(p.col_panels) * kCols)) {}
};

// Q of a block, in panels of kRows runs (K x kRows each, runs contiguous so
// the loops run over them in vectors): each run's W'W, column by column.
void pack_gram(const Plan& p, const double* W, double* Q) {
  const arma::uword n_t = p.n_t, n_x = p.n_x;
  const int block = p.block;
  for (int ip = 0; ip < block / kRows; ++ip) {
    double* q = Q + static_cast<std::size_t>(ip) * p.K * kRows;
    const double* w = W + ip * kRows;
    for (arma::uword l = 0; l < n_x; ++l) {
      for (arma::uword k = 0; k <= l; ++k) {
        const double* wk = w + k * n_t * block;
        const double* wl = w + l * n_t * block;
        double acc[kRows] = {0.0};
        for (arma::uword t = 0; t < n_t; ++t) {
          for (int r = 0; r < kRows; ++r) acc[r] += wk[t * block + r] * wl[t * block + r];
        }
        double* q_kl = q + (l * n_x + k) * kRows;
        double* q_lk = q + (k * n_x + l) * kRows;
        for (int r = 0; r < kRows; ++r) q_kl[r] = q_lk[r] = acc[r];
      }
    }
  }
}

// The residuals of a block (n_t = 1) in the same panels, for whitened_sums().
void pack_residuals(const Plan& p, const double* W, double* Q) {
  for (int ip = 0; ip < p.block / kRows; ++ip) {
    double* q = Q + static_cast<std::size_t>(ip) * p.K * kRows;
    for (arma::uword k = 0; k < p.n_x; ++k, q += kRows) {
      std::copy(W + k * p.block + ip * kRows, W + k * p.block + (ip + 1) * kRows, q);
    }
  }
}

// The AR(1) innovations over t of the block's runs for rho_t value gt (as
// griddy::ar1_innovations(), for the block's runs at once, straight from
// the outputs: residual e_j = y_j - Y_ij), their sums of squares into `ss`,
// and, when `W` is not null, the innovations themselves (column j of W at
// W + j * block).
void block_innovations(const Plan& p, const arma::mat& Y, const arma::vec& y_field,
                       arma::uword first, int rows, arma::uword gt, double* ss, double* W) {
  std::fill(ss, ss + rows, 0.0);
  for (arma::uword j = 0; j < p.n; ++j) {
    const double* yj = Y.colptr(j) + first;
    const double fj = y_field[j];
    double* w = W ? W + j * p.block : nullptr;
    const arma::uword t = j % p.n_t;
    if (t == 0) {
      GRIDDY_SIMD
      for (int r = 0; r < rows; ++r) {
        const double v = fj - yj[r];
        ss[r] += v * v;
      }
      if (w) for (int r = 0; r < rows; ++r) w[r] = fj - yj[r];
      continue;
    }
    const double* y_prev = Y.colptr(j - 1) + first;
    const double f_prev = y_field[j - 1];
    const double phi = p.phi(t - 1, gt);
    const double inv_sd = p.inv_sd(t - 1, gt);
    if (w) {
      GRIDDY_SIMD
      for (int r = 0; r < rows; ++r) {
        const double v = ((fj - yj[r]) - phi * (f_prev - y_prev[r])) * inv_sd;
        w[r] = v;
        ss[r] += v * v;
      }
    } else {
      GRIDDY_SIMD
      for (int r = 0; r < rows; ++r) {
        const double v = ((fj - yj[r]) - phi * (f_prev - y_prev[r])) * inv_sd;
        ss[r] += v * v;
      }
    }
  }
}

// Runs first .. first + rows - 1 (rows <= p.block; the rest of the block is
// padding): their columns of C.
void block_quad_forms(const Plan& p, const arma::mat& Y, const arma::vec& y_field,
                      arma::uword first, int rows, const griddy::Kernels& kernels,
                      Workspace& ws, double* C) {
  double* ss = ws.sum_sq.data();
  double* W = p.dense.empty() ? nullptr : ws.W.data();
  for (arma::uword gt = 0; gt < p.G_t; ++gt) {
    block_innovations(p, Y, y_field, first, rows, gt, ss, W);
    for (int r = 0; r < rows; ++r) ws.finite = ws.finite && std::isfinite(ss[r]);
    for (arma::uword gx : p.identity) {
      std::copy(ss, ss + rows, C + (gx + p.G_x * gt) * p.n_runs + first);
    }
    if (!W) continue;
    const int row_panels = p.block / kRows;
    if (p.whiten) {
      pack_residuals(p, W, ws.Q.data());
      for (std::size_t d = 0; d < p.dense.size(); ++d) {
        griddy::whitened_sums(ws.Q.data(), row_panels, p.K, p.b_packed.data() + d * p.factor_size,
                              ws.C_tile.data() + d * p.block, kernels.square);
      }
    } else {
      pack_gram(p, W, ws.Q.data());
      griddy::tiled_product(ws.Q.data(), row_panels, p.b_packed.data(), p.col_panels, p.K,
                            static_cast<int>(p.n_x), ws.C_tile.data(), p.block, kernels.tile);
    }
    for (std::size_t d = 0; d < p.dense.size(); ++d) {
      const double* c = ws.C_tile.data() + d * p.block;
      for (int r = 0; r < rows; ++r) ws.finite = ws.finite && std::isfinite(c[r]);
      std::copy(c, c + rows, C + (p.dense[d] + p.G_x * gt) * p.n_runs + first);
    }
  }
}

}  // namespace

// `threads` OpenMP threads share the blocks of runs (parallel_waves.h). C is
// written straight into R's memory (no copy on return). `portable = true`
// uses the plain C++ tiles (for tests) instead of the processor's fastest.
// [[Rcpp::export]]
Rcpp::NumericMatrix quad_forms_cpp(const arma::mat& Y, const arma::vec& y_field,
                                   const arma::cube& Rx_inv, const arma::mat& phi,
                                   int threads = 1, bool portable = false) {
  check_quad_form_inputs(Y, y_field, Rx_inv, phi);
  const Plan plan = make_plan(Y, Rx_inv, phi);
  // every entry is written below: no zero-filling pass first
  Rcpp::NumericMatrix C_out = Rcpp::no_init(plan.n_runs, plan.G_x * plan.G_t);
  double* C = C_out.begin();
  threads = griddy::usable_threads(threads);
  const griddy::Kernels kernels = griddy::kernels(portable);
  std::vector<Workspace> work;
  work.reserve(threads);
  for (int k = 0; k < threads; ++k) work.emplace_back(plan);

  const long long n_blocks = (static_cast<long long>(plan.n_runs) + plan.block - 1) / plan.block;
  // waves of about 10^10 floating-point operations per thread (a quarter of a
  // second): a thread that the system deschedules holds up the others only at
  // the end of a wave
  const double per_run_and_point = plan.whiten ? plan.n_x * (plan.n_x + 6.0) : 2.0 * plan.K;
  const double block_cost = static_cast<double>(plan.block) * plan.G_t *
    (plan.n + plan.dense.size() * per_run_and_point + (plan.whiten ? 0.0 : plan.K * plan.n_t));
  const long long wave = threads * std::max(1LL, static_cast<long long>(1e10 / block_cost));
  griddy::parallel_waves(n_blocks, wave, threads, [&](long long b, int thread) {
    const arma::uword first = static_cast<arma::uword>(b) * plan.block;
    const int rows = static_cast<int>(std::min<arma::uword>(plan.block, plan.n_runs - first));
    block_quad_forms(plan, Y, y_field, first, rows, kernels, work[thread], C);
  });
  // An NA, NaN or Inf output, or a squared difference that overflows, makes
  // its misfit non-finite: checked as each block is written, rather than in
  // another pass over the outputs.
  for (const Workspace& ws : work) {
    if (!ws.finite) {
      Rcpp::stop("quad_forms: a misfit is not finite: the outputs hold NA, NaN or Inf, or "
                 "their squared differences from the field data overflow");
    }
  }
  return C_out;
}

// Whether the products use the AVX2/FMA tiles on this processor (for tests
// and benchmarks).
// [[Rcpp::export]]
bool quad_forms_avx2_cpp() {
  return griddy::kernels_use_avx2();
}
