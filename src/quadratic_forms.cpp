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
#include <cmath>
#include <limits>
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
  const struct Missing* missing = nullptr;  // missing cells (below), or none
  const arma::cube* Rx_inv = nullptr;       // with missing cells
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

// `n` cells per run (Y's columns, or the reduced grid's with missing cells,
// which also keep `extra` doubles per run in a block's workspace).
Plan make_plan(const arma::mat& Y, const arma::cube& Rx_inv, const arma::mat& phi,
               arma::uword n = 0, int extra = 0) {
  Plan p;
  p.n_runs = Y.n_rows;
  p.n = n > 0 ? n : Y.n_cols;
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
  const int per_run = static_cast<int>(p.n) + (p.dense.empty() ? 0 : p.K) + extra;
  const int cap = p.dense.empty() ? 512 : 256;
  p.block = std::max(kRows, std::min(cap, ((1 << 19) / std::max(per_run, 1)) / kRows * kRows));
  return p;
}

// One thread's buffers, allocated before the parallel region.
// With missing cells (Missing, below) also the block's residuals E (filled
// at the missing cells), the rows F of R_t^-1 E at the coordinates where a
// cell is missing, and the corrections' vectors U (one per missing cell).
struct Workspace {
  griddy::AlignedBuffer W, sum_sq, Q, C_tile, E, F, U;
  bool finite = true;
  explicit Workspace(const Plan& p);
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

// ---- missing cells ------------------------------------------------------------
//
// A field with missing cells (masked_quad_forms_cpp()) is reduced first (in
// R) to the grid of the x settings and coordinates t that hold a measurement;
// on it, Sigma = R_x (x) R_t is still Kronecker, but some cells o are
// observed and the others m are not, and C = r_o' Sigma_oo^-1 r_o. For any
// values f put in the missing cells (the residual vector r = (r_o, f)),
//   r_o' Sigma_oo^-1 r_o = r' P r - u' P_mm^-1 u,  P = Sigma^-1, u = (P r)_m
// (the Schur complement; the second term is zero when f is the conditional
// mean of the missing cells given the observed ones). So the full field's
// product gives r' P r, and each grid point subtracts u' P_mm^-1 u:
// * f is each setting's AR(1) conditional mean at the missing coordinates
//   (from its nearest observed neighbours, computed in R): exact when R_x =
//   I, so then nothing is subtracted and C is the filled series' innovations
//   alone, and otherwise r' P r and the term subtracted stay of the size of C
//   (no cancellation from a filled value far from the others);
// * P = R_x^-1 (x) R_t^-1 with R_t^-1 tridiagonal: with the missing cells
//   ordered by t, P_mm is block tridiagonal (a block per coordinate holding
//   a missing cell; neighbouring blocks coupled when their t are adjacent)
//   and its Cholesky factor L block bidiagonal, so L^-1 u costs about
//   (missing cells) x (settings) per run, and u = (R_t^-1 E R_x^-1)_m takes
//   R_t^-1 E from the innovations W (R_t^-1 = W_t' W_t) at those rows only.
// log|Sigma_oo| = log|Sigma| + log|P_mm| (missing_logdet_cpp()).
struct Missing {
  std::vector<arma::sword> column;  // library column of each cell, -1: missing
  arma::vec y, scale;               // field value (0 where missing) and 1/sd of each cell
  std::vector<arma::uword> observed;
  // the fill of missing cell k (cell order): cell fill[k] = w_before(k, gt)
  // x cell before[k] + w_after(k, gt) x cell after[k] (-1: none)
  std::vector<arma::uword> fill;
  std::vector<arma::sword> before, after;
  arma::mat w_before, w_after;
  // the missing cells ordered by t, then setting: setting of each, and the
  // blocks of one coordinate each: its t, its first entry (one more at the
  // end), whether the previous block's t is the one before
  std::vector<arma::uword> miss_x, block_t, block_first;
  std::vector<char> adjacent;
  // per block, the offsets of L_{k,k-1} (size_k x size_{k-1}, when adjacent)
  // and of L_kk^-1 (size_k x size_k) in each grid point's factors
  std::vector<std::size_t> sub_at, inv_at;
  std::size_t factor_size = 0;
  // the factors of (rho_t value gt, dense x grid point d) at gt * n_dense + d
  std::vector<std::vector<double>> factors;
  std::vector<double> logdet;  // log|P_mm| likewise
  double offset = 0.0;         // added to every form (the replicates' pure error)
};

// The missing cells' blocks (cells ordered by t then setting) from the
// columns of the reduced grid (n_x settings x n_t coordinates).
void missing_blocks(Missing& m, arma::uword n_x, arma::uword n_t) {
  m.block_first.push_back(0);
  for (arma::uword t = 0; t < n_t; ++t) {
    const std::size_t before = m.miss_x.size();
    for (arma::uword x = 0; x < n_x; ++x) {
      if (m.column[x * n_t + t] < 0) m.miss_x.push_back(x);
    }
    if (m.miss_x.size() == before) continue;
    m.adjacent.push_back(!m.block_t.empty() && m.block_t.back() + 1 == t);
    m.block_t.push_back(t);
    m.block_first.push_back(m.miss_x.size());
  }
  std::size_t at = 0;
  for (std::size_t k = 0; k < m.block_t.size(); ++k) {
    const std::size_t size = m.block_first[k + 1] - m.block_first[k];
    m.sub_at.push_back(at);
    if (m.adjacent[k]) at += size * (m.block_first[k] - m.block_first[k - 1]);
    m.inv_at.push_back(at);
    at += size * size;
  }
  m.factor_size = at;
}

// R_t^-1 of the reduced coordinates (AR(1) lag coefficients phi, 1 / sqrt(1 -
// phi^2) inv_sd at rho_t value gt): its diagonal at t, and its entry (t, t - 1).
double rt_inv_diag(const Plan& p, arma::uword t, arma::uword gt) {
  const double d = t == 0 ? 1.0 : p.inv_sd(t - 1, gt);
  const double below = t + 1 < p.n_t ? p.phi(t, gt) * p.inv_sd(t, gt) : 0.0;
  return d * d + below * below;
}
double rt_inv_lower(const Plan& p, arma::uword t, arma::uword gt) {
  return -p.phi(t - 1, gt) * p.inv_sd(t - 1, gt) * p.inv_sd(t - 1, gt);
}

// The block Cholesky factor of P_mm at (gt, R_x^-1 = Rxi) into f, log|P_mm|
// returned; NaN when P_mm is not numerically positive definite.
double missing_factor(const Missing& m, const Plan& p, const arma::mat& Rxi, arma::uword gt,
                      double* f) {
  double logdet = 0.0;
  arma::mat prev_inv;
  for (std::size_t k = 0; k < m.block_t.size(); ++k) {
    const arma::uword t = m.block_t[k];
    const arma::uvec idx = arma::conv_to<arma::uvec>::from(
      std::vector<arma::uword>(m.miss_x.begin() + m.block_first[k],
                               m.miss_x.begin() + m.block_first[k + 1]));
    arma::mat S = Rxi.submat(idx, idx) * rt_inv_diag(p, t, gt);
    if (m.adjacent[k]) {
      const arma::uvec prev = arma::conv_to<arma::uvec>::from(
        std::vector<arma::uword>(m.miss_x.begin() + m.block_first[k - 1],
                                 m.miss_x.begin() + m.block_first[k]));
      const arma::mat sub = Rxi.submat(idx, prev) * rt_inv_lower(p, t, gt) * prev_inv.t();
      S -= sub * sub.t();
      std::copy(sub.begin(), sub.end(), f + m.sub_at[k]);
    }
    arma::mat L;
    if (!arma::chol(L, S, "lower")) return NAN;
    logdet += 2.0 * arma::accu(arma::log(L.diag()));
    prev_inv = arma::inv(arma::trimatl(L));
    std::copy(prev_inv.begin(), prev_inv.end(), f + m.inv_at[k]);
  }
  return logdet;
}

// Every (gt, dense x grid point)'s factors; false when one fails.
bool missing_factors(Missing& m, const Plan& p, const arma::cube& Rx_inv) {
  m.factors.assign(p.G_t * p.dense.size(), std::vector<double>(m.factor_size, 0.0));
  m.logdet.assign(m.factors.size(), 0.0);
  for (arma::uword gt = 0; gt < p.G_t; ++gt) {
    for (std::size_t d = 0; d < p.dense.size(); ++d) {
      const std::size_t at = gt * p.dense.size() + d;
      m.logdet[at] = missing_factor(m, p, Rx_inv.slice(p.dense[d]), gt, m.factors[at].data());
      if (!std::isfinite(m.logdet[at])) return false;
    }
  }
  return true;
}

// The block's scaled residuals at the observed cells (cell j at E + j * block).
void block_residuals(const Plan& p, const Missing& m, const arma::mat& Y, arma::uword first,
                     int rows, double* E) {
  for (arma::uword j : m.observed) {
    const double* yj = Y.colptr(m.column[j]) + first;
    const double fj = m.y[j], sj = m.scale[j];
    double* e = E + j * p.block;
    GRIDDY_SIMD
    for (int r = 0; r < rows; ++r) e[r] = (fj - yj[r]) * sj;
  }
}

// The missing cells filled for rho_t value gt, then the innovations of the
// filled residuals and their sums of squares (as block_innovations()).
void masked_innovations(const Plan& p, const Missing& m, double* E, int rows, arma::uword gt,
                        double* ss, double* W) {
  for (std::size_t k = 0; k < m.fill.size(); ++k) {
    double* e = E + m.fill[k] * p.block;
    const double* a = m.before[k] >= 0 ? E + m.before[k] * p.block : nullptr;
    const double* b = m.after[k] >= 0 ? E + m.after[k] * p.block : nullptr;
    const double wa = m.w_before(k, gt), wb = m.w_after(k, gt);
    for (int r = 0; r < rows; ++r) e[r] = (a ? wa * a[r] : 0.0) + (b ? wb * b[r] : 0.0);
  }
  std::fill(ss, ss + rows, 0.0);
  for (arma::uword j = 0; j < p.n; ++j) {
    const double* e = E + j * p.block;
    double* w = W ? W + j * p.block : nullptr;
    const arma::uword t = j % p.n_t;
    const double phi = t == 0 ? 0.0 : p.phi(t - 1, gt);
    const double inv_sd = t == 0 ? 1.0 : p.inv_sd(t - 1, gt);
    const double* e_prev = t == 0 ? e : e - p.block;
    GRIDDY_SIMD
    for (int r = 0; r < rows; ++r) {
      const double v = (e[r] - phi * e_prev[r]) * inv_sd;
      if (w) w[r] = v;
      ss[r] += v * v;
    }
  }
}

// Each dense x grid point's u' P_mm^-1 u subtracted from its column of
// C_tile (which holds r' P r), for rho_t value gt.
void subtract_corrections(const Plan& p, const Missing& m, arma::uword gt, const double* W,
                          int rows, Workspace& ws) {
  const int block = p.block;
  const arma::uword n_x = p.n_x, n_t = p.n_t;
  // F: rows of R_t^-1 E = W_t' W at the blocks' coordinates, by setting
  double* F = ws.F.data();
  for (std::size_t k = 0; k < m.block_t.size(); ++k) {
    const arma::uword t = m.block_t[k];
    const double d = t == 0 ? 1.0 : p.inv_sd(t - 1, gt);
    const double below = t + 1 < n_t ? -p.phi(t, gt) * p.inv_sd(t, gt) : 0.0;
    for (arma::uword x = 0; x < n_x; ++x) {
      const double* w = W + (x * n_t + t) * block;
      double* out = F + (k * n_x + x) * block;
      if (below != 0.0) {
        GRIDDY_SIMD
        for (int r = 0; r < rows; ++r) out[r] = d * w[r] + below * w[r + block];
      } else {
        GRIDDY_SIMD
        for (int r = 0; r < rows; ++r) out[r] = d * w[r];
      }
    }
  }
  double* U = ws.U.data();
  for (std::size_t di = 0; di < p.dense.size(); ++di) {
    const double* R = p.Rx_inv->slice(p.dense[di]).memptr();
    const double* f = m.factors[gt * p.dense.size() + di].data();
    double* c = ws.C_tile.data() + di * block;
    for (std::size_t k = 0; k < m.block_t.size(); ++k) {
      const std::size_t lo = m.block_first[k], size = m.block_first[k + 1] - lo;
      const double* Fk = F + k * n_x * block;
      // u = F R_x^-1 at the missing settings, less L_{k,k-1} z_{k-1}
      for (std::size_t i = 0; i < size; ++i) {
        double* u = U + (lo + i) * block;
        const double* Ra = R + m.miss_x[lo + i] * n_x;
        std::fill(u, u + rows, 0.0);
        for (arma::uword x = 0; x < n_x; ++x) {
          const double* fx = Fk + x * block;
          const double a = Ra[x];
          GRIDDY_SIMD
          for (int r = 0; r < rows; ++r) u[r] += a * fx[r];
        }
        if (!m.adjacent[k]) continue;
        const std::size_t prev_lo = m.block_first[k - 1];
        for (std::size_t j = 0; j < lo - prev_lo; ++j) {
          const double l = f[m.sub_at[k] + j * size + i];
          const double* z = U + (prev_lo + j) * block;
          GRIDDY_SIMD
          for (int r = 0; r < rows; ++r) u[r] -= l * z[r];
        }
      }
      // z = L_kk^-1 v in place, last entry first (each reads the v before it)
      const double* inv = f + m.inv_at[k];
      for (std::size_t i = size; i-- > 0;) {
        double* z = U + (lo + i) * block;
        const double li = inv[i * size + i];
        GRIDDY_SIMD
        for (int r = 0; r < rows; ++r) z[r] *= li;
        for (std::size_t j = 0; j < i; ++j) {
          const double l = inv[j * size + i];
          const double* v = U + (lo + j) * block;
          GRIDDY_SIMD
          for (int r = 0; r < rows; ++r) z[r] += l * v[r];
        }
        GRIDDY_SIMD
        for (int r = 0; r < rows; ++r) c[r] -= z[r] * z[r];
      }
    }
  }
}

Workspace::Workspace(const Plan& p)
    : W(p.dense.empty() ? 0 : p.n * p.block), sum_sq(p.block),
      Q(p.dense.empty() ? 0 : static_cast<std::size_t>(p.K) * p.block),
      C_tile(static_cast<std::size_t>(p.block) *
             (p.whiten ? p.dense.size() : static_cast<std::size_t>(p.col_panels) * kCols)) {
  if (!p.missing) return;
  E.resize(p.n * p.block);
  F.resize(p.missing->block_t.size() * p.n_x * p.block);
  U.resize(p.missing->miss_x.size() * p.block);
}

Rcpp::NumericMatrix run_quad_forms(const Plan& plan, const arma::mat& Y,
                                   const arma::vec& y_field, int threads, bool portable);

// Runs first .. first + rows - 1 (rows <= p.block; the rest of the block is
// padding): their columns of C.
void block_quad_forms(const Plan& p, const arma::mat& Y, const arma::vec& y_field,
                      arma::uword first, int rows, const griddy::Kernels& kernels,
                      Workspace& ws, double* C) {
  double* ss = ws.sum_sq.data();
  double* W = p.dense.empty() ? nullptr : ws.W.data();
  const Missing* miss = p.missing;
  if (miss) block_residuals(p, *miss, Y, first, rows, ws.E.data());
  const double offset = miss ? miss->offset : 0.0;
  for (arma::uword gt = 0; gt < p.G_t; ++gt) {
    if (miss) {
      masked_innovations(p, *miss, ws.E.data(), rows, gt, ss, W);
    } else {
      block_innovations(p, Y, y_field, first, rows, gt, ss, W);
    }
    for (int r = 0; r < rows; ++r) ws.finite = ws.finite && std::isfinite(ss[r]);
    for (arma::uword gx : p.identity) {
      double* c = C + (gx + p.G_x * gt) * p.n_runs + first;
      for (int r = 0; r < rows; ++r) c[r] = ss[r] + offset;
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
    if (miss) subtract_corrections(p, *miss, gt, W, rows, ws);
    for (std::size_t d = 0; d < p.dense.size(); ++d) {
      const double* c = ws.C_tile.data() + d * p.block;
      for (int r = 0; r < rows; ++r) ws.finite = ws.finite && std::isfinite(c[r]);
      double* out = C + (p.dense[d] + p.G_x * gt) * p.n_runs + first;
      for (int r = 0; r < rows; ++r) out[r] = c[r] + offset;
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
  return run_quad_forms(make_plan(Y, Rx_inv, phi), Y, y_field, threads, portable);
}

namespace {

// C of a plan, in blocks of runs on `threads` threads.
Rcpp::NumericMatrix run_quad_forms(const Plan& plan, const arma::mat& Y,
                                   const arma::vec& y_field, int threads, bool portable) {
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

// The cells of a reduced grid (n_x settings x n_t coordinates, blocks of n_t
// by setting), each a library column or -1 where missing, with its 1/sd, and
// its blocks of missing cells; the shapes checked against the outputs'.
Missing missing_cells(const Rcpp::IntegerVector& column, const arma::vec& scale,
                      arma::uword n_x, arma::uword n_t, arma::uword n_outputs) {
  Missing m;
  if (static_cast<arma::uword>(column.size()) != n_x * n_t || scale.n_elem != n_x * n_t) {
    Rcpp::stop("quad_forms: %d cells and %d scales for %d x %d settings and coordinates",
               static_cast<int>(column.size()), static_cast<int>(scale.n_elem),
               static_cast<int>(n_x), static_cast<int>(n_t));
  }
  for (R_xlen_t j = 0; j < column.size(); ++j) {
    if (column[j] >= static_cast<int>(n_outputs) || column[j] < -1) {
      Rcpp::stop("quad_forms: cell %d reads output %d of %d", static_cast<int>(j),
                 column[j], static_cast<int>(n_outputs));
    }
    m.column.push_back(column[j]);
    if (column[j] >= 0) m.observed.push_back(j); else m.fill.push_back(j);
  }
  m.scale = scale;
  missing_blocks(m, n_x, n_t);
  return m;
}

}  // namespace

// C over the observed cells of a field with missing cells (see Missing
// above), on the reduced grid of the settings and coordinates that hold a
// measurement: `column` the library column of each cell (0-based, -1 where
// missing), `y_cells` and `scale` each cell's field value and 1/sd, Rx_inv
// and phi the reduced grid's R_x^-1 (one slice per x grid point) and AR(1)
// lag coefficients, `fill_before`/`fill_after` (0-based cells, -1: none) and
// `w_before`/`w_after` (one row per missing cell, in cell order; one column
// per rho_t value) each missing cell's fill, and `offset` added to every
// form (the replicates' pure error).
// [[Rcpp::export]]
Rcpp::NumericMatrix masked_quad_forms_cpp(const arma::mat& Y, const arma::vec& y_cells,
                                          const Rcpp::IntegerVector& column,
                                          const arma::vec& scale, const arma::cube& Rx_inv,
                                          const arma::mat& phi,
                                          const Rcpp::IntegerVector& fill_before,
                                          const Rcpp::IntegerVector& fill_after,
                                          const arma::mat& w_before, const arma::mat& w_after,
                                          double offset, int threads = 1,
                                          bool portable = false) {
  const arma::uword n_x = Rx_inv.n_rows, n_t = phi.n_rows + 1;
  Missing m = missing_cells(column, scale, n_x, n_t, Y.n_cols);
  const std::size_t n_fill = m.fill.size();
  if (y_cells.n_elem != n_x * n_t || Rx_inv.n_cols != n_x ||
      static_cast<std::size_t>(fill_before.size()) != n_fill ||
      static_cast<std::size_t>(fill_after.size()) != n_fill || w_before.n_rows != n_fill ||
      w_after.n_rows != n_fill || w_before.n_cols != phi.n_cols ||
      w_after.n_cols != phi.n_cols) {
    Rcpp::stop("quad_forms: the missing cells' shapes do not match");
  }
  for (arma::uword j : m.observed) {
    if (!std::isfinite(y_cells[j])) Rcpp::stop("quad_forms: the field data hold NA, NaN or Inf");
  }
  for (std::size_t k = 0; k < n_fill; ++k) {
    for (int v : {fill_before[k], fill_after[k]}) {
      if (v >= 0 && (v >= static_cast<int>(n_x * n_t) || m.column[v] < 0)) {
        Rcpp::stop("quad_forms: a missing cell is filled from a cell that is not observed");
      }
    }
    m.before.push_back(fill_before[k]);
    m.after.push_back(fill_after[k]);
  }
  m.y = y_cells;
  m.w_before = w_before;
  m.w_after = w_after;
  m.offset = offset;
  const int extra = static_cast<int>(n_x * n_t + (m.block_t.size() * n_x) + m.miss_x.size());
  Plan plan = make_plan(Y, Rx_inv, phi, n_x * n_t, extra);
  plan.whiten = plan.whiten && n_fill == 0;
  plan.missing = &m;
  plan.Rx_inv = &Rx_inv;
  if (!missing_factors(m, plan, Rx_inv)) {
    Rcpp::stop("quad_forms: the correlation of the missing cells is numerically singular");
  }
  return run_quad_forms(plan, Y, y_cells, threads, portable);
}

// log|P_mm| (see Missing above) at every grid point of the reduced grid
// (x grid points fastest), for the log-determinant of the observed cells'
// correlation: log|Sigma_oo| = log|Sigma| + log|P_mm|. NaN where P_mm is not
// numerically positive definite.
// [[Rcpp::export]]
Rcpp::NumericVector missing_logdet_cpp(const Rcpp::IntegerVector& column, const arma::cube& Rx_inv,
                                       const arma::mat& phi) {
  const arma::uword n_x = Rx_inv.n_rows, n_t = phi.n_rows + 1;
  Missing m = missing_cells(column, arma::ones(n_x * n_t), n_x, n_t,
                            std::numeric_limits<int>::max());
  Plan p;
  p.n_t = n_t;
  p.phi = phi;
  p.inv_sd = 1.0 / arma::sqrt(1.0 - arma::square(phi));
  std::vector<double> f(m.factor_size);
  Rcpp::NumericVector out(Rx_inv.n_slices * phi.n_cols);
  for (arma::uword gt = 0; gt < phi.n_cols; ++gt) {
    for (arma::uword gx = 0; gx < Rx_inv.n_slices; ++gx) {
      out[gt * Rx_inv.n_slices + gx] = missing_factor(m, p, Rx_inv.slice(gx), gt, f.data());
    }
  }
  return out;
}

// Whether the products use the AVX2/FMA tiles on this processor (for tests
// and benchmarks).
// [[Rcpp::export]]
bool quad_forms_avx2_cpp() {
  return griddy::kernels_use_avx2();
}
