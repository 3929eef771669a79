// next_measurement()'s per-candidate work (R/next-measurement.R) in one pass
// over all candidates: each kept component's Student-t predictive at the
// candidate (location, scale; AR(1) conditional on the nearest measured
// neighbours), the merge (merge_components.h), and the mixture entropies
// by Gauss-Legendre quadrature, as the tests' plain-R reference
// candidate_information() (tests/testthat/helper-next-measurement.R) does.
// R's vector passes per candidate cost more than this whole loop.
#include <Rcpp.h>
#include <algorithm>
#include <cmath>
#include <vector>
#include "merge_components.h"

namespace {

double t_entropy_const(double v) {
  return (v + 1) / 2 * (R::digamma((v + 1) / 2) - R::digamma(v / 2)) +
         std::log(std::sqrt(v) * R::beta(v / 2, 0.5));
}

double t_log_const(double v) {
  return R::lgammafn((v + 1) / 2) - R::lgammafn(v / 2) - std::log(v * M_PI) / 2;
}

// the quadrature nodes (Student-t quantiles at the rule's u) of each nu met
struct Quantiles {
  const std::vector<double>& u;
  std::vector<double> nus;
  std::vector<std::vector<double>> z;
  explicit Quantiles(const std::vector<double>& u_) : u(u_) {}
  const std::vector<double>& at(double v) {
    for (size_t k = 0; k < nus.size(); ++k) if (nus[k] == v) return z[k];
    nus.push_back(v);
    std::vector<double> q(u.size());
    for (size_t i = 0; i < u.size(); ++i) q[i] = R::qt(u[i], v, 1, 0);
    z.push_back(q);
    return z.back();
  }
};

// p[i] += amp (1 + ((y[i] - m) / s)^2 / nu)^(-(nu + 1) / 2) for i < n: the
// power by products and a square root when nu is a whole number (a whole
// prior shape: nu = 2a + n), else by exp and log; the same value to rounding.
void add_t_kernel(const double* y, size_t n, double m, double inv_s, double nu, double amp,
                  double* p) {
  const double inv_nu = 1 / nu;
  if (nu == std::floor(nu) && nu <= 256) {
    const int whole = static_cast<int>(nu + 1) / 2;
    const bool half = static_cast<int>(nu + 1) % 2 == 1;
    for (size_t i = 0; i < n; ++i) {
      const double d = (y[i] - m) * inv_s;
      double r = 1 / (1 + d * d * inv_nu);
      double v = half ? std::sqrt(r) : 1.0;
      for (int e = whole; e > 0; e >>= 1) {
        if (e & 1) v *= r;
        r *= r;
      }
      p[i] += amp * v;
    }
  } else {
    const double expo = -(nu + 1) / 2;
    for (size_t i = 0; i < n; ++i) {
      const double d = (y[i] - m) * inv_s;
      p[i] += amp * std::exp(expo * std::log1p(d * d * inv_nu));
    }
  }
}

// The entropy of the mixture sum w t_nu(m, s) / total, and with several
// classes (models) the class-weighted sum of each class's own mixture
// entropy: merged once (a merged component keeps to one class), then
// sum_j w_j [H(p_j) + KL(p_j || p)] by quadrature over p_j's quantiles, with
// p the whole mixture or p_j's class's part; one pass of kernels gives both.
struct Entropies {
  double mix, classes;
};

Entropies mixture_entropies(const double* w, const double* m, const double* s, const double* ls,
                            const int* cls, long n, const griddy::Bounds& bounds,
                            double total,
                            const std::vector<double>& class_nu,
                            const std::vector<double>& class_mass,
                            const std::vector<double>& weight, Quantiles& quant,
                            int max_components) {
  if (n == 0) return {0, 0};
  const int C = class_nu.size();
  griddy::Merged mc;
  if (n == 1) {
    mc.w = {w[0]};
    mc.m = {m[0]};
    mc.s2 = {s[0] * s[0]};
    mc.nu_class = {cls[0]};
  } else {
    griddy::merge_components(w, m, s, ls, cls, n, C, 0.25, 0.05, max_components, mc,
                             &bounds);
  }
  const size_t J = mc.w.size();
  std::vector<double> wj(J), sj(J), lsj(J), nu(J), c_log(J), c_ent(J);
  for (size_t j = 0; j < J; ++j) {
    wj[j] = mc.w[j] / total;
    sj[j] = std::sqrt(mc.s2[j]);
    lsj[j] = std::log(sj[j]);
    nu[j] = class_nu[mc.nu_class[j] - 1];
    c_log[j] = t_log_const(nu[j]);
    c_ent[j] = t_entropy_const(nu[j]);
  }
  if (J == 1) return {lsj[0] + c_ent[0], lsj[0] + c_ent[0]};
  // the nodes, Q per component, and each class's density there
  const size_t Q = weight.size(), P = J * Q;
  std::vector<double> y(P), p(C * P, 0.0);
  for (size_t j = 0; j < J; ++j) {
    const std::vector<double>& z = quant.at(nu[j]);
    for (size_t q = 0; q < Q; ++q) y[j * Q + q] = z[q] * sj[j] + mc.m[j];
  }
  for (size_t k = 0; k < J; ++k) {
    add_t_kernel(y.data(), P, mc.m[k], 1 / sj[k], nu[k], std::exp(c_log[k]) * wj[k] / sj[k],
                 &p[(mc.nu_class[k] - 1) * P]);
  }
  std::vector<double> log_mass(C);
  for (int c = 0; c < C; ++c) log_mass[c] = std::log(class_mass[c] / total);
  double h_mix = 0, h_classes = 0;
  for (size_t j = 0; j < J; ++j) {
    const std::vector<double>& z = quant.at(nu[j]);
    const int c = mc.nu_class[j] - 1;
    double kl = 0, kl_class = 0;
    for (size_t q = 0; q < Q; ++q) {
      const size_t i = j * Q + q;
      const double log_pj = c_log[j] - (nu[j] + 1) / 2 * std::log1p(z[q] * z[q] / nu[j]) -
                            lsj[j];
      double p_all = 0;
      for (int c2 = 0; c2 < C; ++c2) p_all += p[c2 * P + i];
      kl += weight[q] * (log_pj - std::log(p_all));
      if (C > 1) kl_class += weight[q] * (log_pj - std::log(p[c * P + i]) + log_mass[c]);
    }
    h_mix += wj[j] * (lsj[j] + c_ent[j] + kl);
    h_classes += wj[j] * (lsj[j] + c_ent[j] + kl_class);
  }
  return {h_mix, C > 1 ? h_classes : h_mix};
}

}  // namespace

// models: per model a list of w, run, g (0-based, per kept component), rho
// (per grid point), outputs (runs x library columns), scale2 (components x
// noise groups: (b + C/2) / (a + n/2)), and per candidate: column, group
// (0-based), nu, before/after (measured neighbour columns, -1 for none),
// y_before/y_after, lag_before/lag_after (distances in unit t). Returns
// 2 x candidates: gain, gain_model (NA with one model).
// [[Rcpp::export]]
Rcpp::NumericMatrix next_gains_cpp(const Rcpp::List& models, int n_candidates,
                                   const std::vector<double>& u,
                                   const std::vector<double>& weight, int max_components) {
  const int M = models.size();
  Quantiles quant(u);
  Rcpp::NumericMatrix out(2, n_candidates);
  std::vector<long> start(M + 1, 0);
  int n_groups_max = 1;
  for (int mod = 0; mod < M; ++mod) {
    const Rcpp::List part = models[mod];
    const Rcpp::NumericMatrix scale2 = part["scale2"];
    const Rcpp::NumericVector pw = part["w"];
    n_groups_max = std::max(n_groups_max, static_cast<int>(scale2.ncol()));
    start[mod + 1] = start[mod] + pw.size();
  }
  const long n = start[M];
  std::vector<double> m(n), s(n), ls(n);
  // a component's class in the merge is its model: a merged component keeps
  // to one model, so one merge serves the mixture and each model's part
  std::vector<int> cls(n);
  for (int mod = 0; mod < M; ++mod) {
    std::fill(cls.begin() + start[mod], cls.begin() + start[mod + 1], mod + 1);
  }
  // the weights, the same at every candidate
  std::vector<double> w(n);
  for (int mod = 0; mod < M; ++mod) {
    const Rcpp::List part = models[mod];
    const Rcpp::NumericVector pw = part["w"];
    std::copy(pw.begin(), pw.end(), w.begin() + start[mod]);
  }
  double total = 0;
  for (double v : w) total += v;
  std::vector<double> mass(M, 0.0);
  for (int mod = 0; mod < M; ++mod) {
    for (long i = start[mod]; i < start[mod + 1]; ++i) mass[mod] += w[i];
  }
  // each (model, noise group)'s scales without a neighbour, and their logs,
  // computed once; a neighbour multiplies a scale by sqrt(var) per grid point
  std::vector<std::vector<double>> cache_s(M * n_groups_max), cache_ls(M * n_groups_max);
  std::vector<double> class_nu(M);
  for (int j = 0; j < n_candidates; ++j) {
    double h_comp = 0;
    griddy::Bounds bounds;
    for (int mod = 0; mod < M; ++mod) {
      const Rcpp::List part = models[mod];
      const Rcpp::NumericVector rho = part["rho"], nu = part["nu"];
      const Rcpp::IntegerVector run = part["run"], g = part["g"], column = part["column"],
                                group = part["group"], before = part["before"],
                                after = part["after"];
      const Rcpp::NumericVector y_before = part["y_before"], y_after = part["y_after"],
                                lag_before = part["lag_before"], lag_after = part["lag_after"];
      const Rcpp::NumericMatrix outputs = part["outputs"], scale2 = part["scale2"];
      const int N = outputs.nrow();
      const double* col = &outputs[static_cast<R_xlen_t>(column[j]) * N];
      const bool has_b = before[j] >= 0, has_a = after[j] >= 0;
      const double* col_b = has_b ? &outputs[static_cast<R_xlen_t>(before[j]) * N] : nullptr;
      const double* col_a = has_a ? &outputs[static_cast<R_xlen_t>(after[j]) * N] : nullptr;
      const int G = rho.size();
      std::vector<double> p1(G, 0.0), p2(G, 0.0), d(G, 1.0), var(G, 1.0), sd(G, 1.0),
          log_sd(G, 0.0);
      for (int k = 0; k < G; ++k) {
        if (has_b) p1[k] = std::pow(rho[k], lag_before[j]);
        if (has_a) p2[k] = std::pow(rho[k], lag_after[j]);
        d[k] = 1 - p1[k] * p1[k] * p2[k] * p2[k];
        var[k] = (1 - p1[k] * p1[k]) * (1 - p2[k] * p2[k]) / d[k];
        sd[k] = std::sqrt(var[k]);
        log_sd[k] = std::log(sd[k]);
      }
      class_nu[mod] = nu[j];
      std::vector<double>& cs = cache_s[mod * n_groups_max + group[j]];
      std::vector<double>& cl = cache_ls[mod * n_groups_max + group[j]];
      const long K = start[mod + 1] - start[mod];
      if (cs.empty()) {
        const double* sc = &scale2[static_cast<R_xlen_t>(group[j]) * scale2.nrow()];
        cs.resize(K);
        cl.resize(K);
        for (long i = 0; i < K; ++i) {
          cs[i] = std::sqrt(sc[i]);
          cl[i] = std::log(cs[i]);
        }
      }
      const double ent = t_entropy_const(nu[j]);
      double* mi = &m[start[mod]];
      double* si = &s[start[mod]];
      double* lsi = &ls[start[mod]];
      const double* wi = &w[start[mod]];
      double sum_wls = 0;
      if (has_b || has_a) {
        for (long i = 0; i < K; ++i) {
          const int r = run[i], gi = g[i];
          const double e1 = has_b ? y_before[j] - col_b[r] : 0.0;
          const double e2 = has_a ? y_after[j] - col_a[r] : 0.0;
          mi[i] = col[r] + (p1[gi] * (1 - p2[gi] * p2[gi]) * e1 +
                            p2[gi] * (1 - p1[gi] * p1[gi]) * e2) / d[gi];
          si[i] = cs[i] * sd[gi];
          lsi[i] = cl[i] + log_sd[gi];
          sum_wls += wi[i] * lsi[i];
          bounds.add(mi[i], lsi[i]);
        }
      } else {
        for (long i = 0; i < K; ++i) {
          mi[i] = col[run[i]];
          sum_wls += wi[i] * cl[i];
          bounds.add(mi[i], cl[i]);
        }
        std::copy(cs.begin(), cs.end(), si);
        std::copy(cl.begin(), cl.end(), lsi);
      }
      h_comp += (sum_wls + mass[mod] * ent) / total;
    }
    const Entropies h = mixture_entropies(w.data(), m.data(), s.data(), ls.data(), cls.data(),
                                          n, bounds, total, class_nu, mass, weight, quant,
                                          max_components * M);
    out(0, j) = std::max(h.mix - h_comp, 0.0);
    out(1, j) = M > 1 ? std::max(h.mix - h.classes, 0.0) : NA_REAL;
  }
  return out;
}
