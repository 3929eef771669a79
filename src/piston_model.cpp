// Steady axisymmetric conduction in a piston crown: finite-volume system
// solved once per operating condition, then a small dense solve per set of
// the three unknown heat-transfer coefficients.
//
// The R side (R/standin-piston.R) builds the geometry, the conductances and the
// boundary faces and validates everything; the functions here trust their
// inputs.

#include <RcppArmadillo.h>
#include <cmath>

namespace {

// Lower band of an SPD matrix, stored as lb(i - j, j) = A(i, j), 0 <= i - j <= bw.
// Factorised in place into its Cholesky factor L (same storage).
void band_cholesky(arma::mat& lb, arma::uword bw) {
  const arma::uword n = lb.n_cols;
  for (arma::uword j = 0; j < n; ++j) {
    const arma::uword k0 = (j > bw) ? j - bw : 0;
    double s = lb(0, j);
    for (arma::uword k = k0; k < j; ++k) {
      const double l = lb(j - k, k);
      s -= l * l;
    }
    if (!(s > 0.0)) {
      Rcpp::stop("piston conduction matrix is not positive definite (pivot %d)",
                 static_cast<int>(j));
    }
    const double djj = std::sqrt(s);
    lb(0, j) = djj;
    const arma::uword imax = std::min(n - 1, j + bw);
    for (arma::uword i = j + 1; i <= imax; ++i) {
      const arma::uword kk0 = (i > bw) ? i - bw : 0;
      double t = lb(i - j, j);
      for (arma::uword k = std::max(k0, kk0); k < j; ++k) {
        t -= lb(i - k, k) * lb(j - k, k);
      }
      lb(i - j, j) = t / djj;
    }
  }
}

// Solve L L' X = B in place (B overwritten by X), L from band_cholesky().
void band_solve(const arma::mat& lb, arma::uword bw, arma::mat& b) {
  const arma::uword n = lb.n_cols;
  for (arma::uword c = 0; c < b.n_cols; ++c) {
    double* x = b.colptr(c);
    for (arma::uword i = 0; i < n; ++i) {  // forward: L y = b
      const arma::uword k0 = (i > bw) ? i - bw : 0;
      double s = x[i];
      for (arma::uword k = k0; k < i; ++k) s -= lb(i - k, k) * x[k];
      x[i] = s / lb(0, i);
    }
    for (arma::uword ii = n; ii-- > 0;) {  // backward: L' x = y
      const arma::uword kmax = std::min(n - 1, ii + bw);
      double s = x[ii];
      for (arma::uword k = ii + 1; k <= kmax; ++k) s -= lb(k - ii, ii) * x[k];
      x[ii] = s / lb(0, ii);
    }
  }
}

// Solve A x = b in place for a small SPD matrix A (overwritten by its upper
// Cholesky factor U, A = U'U); b is overwritten by x.  Column-oriented so that
// the inner loops run over contiguous memory.  Returns false if A is not SPD.
bool dense_chol_solve(arma::mat& a, arma::vec& b) {
  const arma::uword n = a.n_rows;
  for (arma::uword j = 0; j < n; ++j) {
    double* cj = a.colptr(j);
    for (arma::uword i = 0; i <= j; ++i) {
      const double* ci = a.colptr(i);
      double s = cj[i];
      for (arma::uword k = 0; k < i; ++k) s -= ci[k] * cj[k];
      if (i < j) {
        cj[i] = s / ci[i];
      } else {
        if (!(s > 0.0)) return false;
        cj[j] = std::sqrt(s);
      }
    }
  }
  double* x = b.memptr();
  for (arma::uword i = 0; i < n; ++i) {  // U' y = b
    const double* ci = a.colptr(i);
    double s = x[i];
    for (arma::uword k = 0; k < i; ++k) s -= ci[k] * x[k];
    x[i] = s / ci[i];
  }
  for (arma::uword j = n; j-- > 0;) {  // U x = y
    const double* cj = a.colptr(j);
    x[j] /= cj[j];
    const double xj = x[j];
    for (arma::uword k = 0; k < j; ++k) x[k] -= cj[k] * xj;
  }
  return true;
}

// Temperatures of the cells carrying HTC faces for one set of coefficients.
// Z_SS = (M0^-1)[S, S], T0_S = (M0^-1 b0)[S]; cell conductance G and source w
// summed over the cell's HTC faces.  Solves (I + Z_SS G) T_S = T0_S + Z_SS w.
arma::vec solve_surface_cells(const arma::mat& zss, const arma::vec& t0s,
                              const arma::uvec& face_cell,
                              const arma::uvec& face_surface,
                              const arma::vec& face_area,
                              const arma::vec& face_rhalf,
                              const arma::vec& t_fluid, const double* h,
                              arma::vec& gcell, arma::vec& wcell, arma::mat& a) {
  gcell.zeros();
  wcell.zeros();
  for (arma::uword f = 0; f < face_cell.n_elem; ++f) {
    const arma::uword s = face_surface(f);
    const double g = face_area(f) / (face_rhalf(f) + 1.0 / h[s]);
    gcell(face_cell(f)) += g;
    wcell(face_cell(f)) += g * t_fluid(s);
  }
  // (I + Z G) T = r  <=>  (Z + G^-1) u = r with u = G T; Z + G^-1 is
  // symmetric positive definite (every S cell has an HTC face, so G > 0).
  a = zss;
  a.diag() += 1.0 / gcell;
  arma::vec rhs = t0s + zss * wcell;
  arma::vec u = rhs;
  if (!dense_chol_solve(a, u)) {
    Rcpp::stop("piston surface system is not positive definite");
  }
  arma::vec ts = u / gcell;
  return ts;
}

}  // namespace

// Assemble the conduction matrix with all fixed boundaries (M0, b0), factorise
// it (banded Cholesky) and return Z = M0^-1 E_S (n x nS) and T0 = M0^-1 b0.
// pair_i < pair_j are 0-based solid-cell indices with pair_j - pair_i <= bw.
// [[Rcpp::export]]
Rcpp::List piston_precompute_cpp(int n, int bw, const arma::uvec& pair_i,
                                 const arma::uvec& pair_j, const arma::vec& pair_g,
                                 const arma::vec& diag_fixed,
                                 const arma::vec& rhs_fixed,
                                 const arma::uvec& s_cells) {
  const arma::uword nn = static_cast<arma::uword>(n);
  const arma::uword bb = static_cast<arma::uword>(bw);
  arma::mat lb(bb + 1, nn, arma::fill::zeros);
  lb.row(0) = diag_fixed.t();
  for (arma::uword p = 0; p < pair_i.n_elem; ++p) {
    const arma::uword i = pair_i(p), j = pair_j(p);
    lb(0, i) += pair_g(p);
    lb(0, j) += pair_g(p);
    lb(j - i, i) -= pair_g(p);
  }
  band_cholesky(lb, bb);
  arma::mat rhs(nn, s_cells.n_elem + 1, arma::fill::zeros);
  for (arma::uword s = 0; s < s_cells.n_elem; ++s) rhs(s_cells(s), s) = 1.0;
  rhs.col(s_cells.n_elem) = rhs_fixed;
  band_solve(lb, bb, rhs);
  return Rcpp::List::create(
      Rcpp::Named("Z") = rhs.cols(0, s_cells.n_elem - 1),
      Rcpp::Named("T0") = rhs.col(s_cells.n_elem));
}

// Face temperatures at the output faces for each row of htc (N x 3).
// face_* describe all HTC faces (cell index into S, surface 0..2, area,
// half-cell resistance d/(2k)); out_faces indexes those faces.
// If out_faces is empty, the temperatures of all S cells are returned instead.
// [[Rcpp::export]]
arma::mat piston_eval_cpp(const arma::mat& zss, const arma::vec& t0s,
                          const arma::uvec& face_cell,
                          const arma::uvec& face_surface,
                          const arma::vec& face_area,
                          const arma::vec& face_rhalf, const arma::vec& t_fluid,
                          const arma::mat& htc, const arma::uvec& out_faces) {
  const arma::uword ns = zss.n_rows;
  const arma::uword nrun = htc.n_rows;
  const bool cells_only = out_faces.n_elem == 0;
  arma::mat out(nrun, cells_only ? ns : out_faces.n_elem);
  arma::vec gcell(ns), wcell(ns);
  arma::mat a(ns, ns);
  double h[3];
  for (arma::uword r = 0; r < nrun; ++r) {
    if (r % 256 == 0) Rcpp::checkUserInterrupt();
    for (int s = 0; s < 3; ++s) h[s] = htc(r, s);
    arma::vec ts = solve_surface_cells(zss, t0s, face_cell, face_surface, face_area,
                                       face_rhalf, t_fluid, h, gcell, wcell, a);
    if (cells_only) {
      out.row(r) = ts.t();
      continue;
    }
    for (arma::uword o = 0; o < out_faces.n_elem; ++o) {
      const arma::uword f = out_faces(o);
      const arma::uword s = face_surface(f);
      const double gk = 1.0 / face_rhalf(f);
      out(r, o) = (gk * ts(face_cell(f)) + h[s] * t_fluid(s)) / (gk + h[s]);
    }
  }
  return out;
}
