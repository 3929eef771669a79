// Vertical dynamics of one wheel on a constant-load tyre rig rolling over a
// cleat (Stewart 2023, chapter 5 stand-in).  Fixed-step RK4 on the wheel-centre
// height; Fiala or PAC2002-style vertical force; point-follower, rigid-disc or
// rectangular-patch (uniform pressure) contact.
//
// All inputs are SI and validated on the R side (R/standin-tyre.R).

#include <RcppArmadillo.h>
#include <cmath>
#include <algorithm>

namespace {

const double kPi = 3.14159265358979323846;

struct TyreSettings {
  int model;             // 0 = Fiala, 1 = PAC2002-style
  int contact;           // 0 = point follower, 1 = rigid disc, 2 = rectangular patch
  double load, speed, mass, r0, fz0;
  double qfz2, qfz3, qpfz1, qv2, v0, camber, dpi;
  double cleat_length, edge_length, t_cleat;
  int n_samples, steps_per_sample;
  double sample_interval;
  bool sample_mean;
  double bottom_stiffness, bottom_deflection;
  double patch_length;   // m; 0 = the chord of the unloaded tyre at its static deflection
};

// Cleat: flat road with a plank of height h and length L whose edges rise
// over edge length b with a half-cosine (C1 profile), starting at x = xc.
struct Cleat {
  double xc, len, b, h;
  double height(double x) const {
    const double s = x - xc;
    if (s <= 0.0 || s >= len) return 0.0;
    if (s < b) return 0.5 * h * (1.0 - std::cos(kPi * s / b));
    if (s > len - b) return 0.5 * h * (1.0 - std::cos(kPi * (len - s) / b));
    return h;
  }
  double slope(double x) const {
    const double s = x - xc;
    if (s <= 0.0 || s >= len) return 0.0;
    if (s < b) return 0.5 * h * kPi / b * std::sin(kPi * s / b);
    if (s > len - b) return -0.5 * h * kPi / b * std::sin(kPi * (len - s) / b);
    return 0.0;
  }
  // Area under the profile from the cleat's start to x (the antiderivative of
  // height(); each half-cosine ramp holds h b / 2).
  double area(double x) const {
    const double s = x - xc;
    if (s <= 0.0) return 0.0;
    const double total = h * (len - b);
    if (s >= len) return total;
    if (s < b) return 0.5 * h * (s - b / kPi * std::sin(kPi * s / b));
    const double r = len - s;
    if (r < b) return total - 0.5 * h * (r - b / kPi * std::sin(kPi * r / b));
    return 0.5 * h * b + h * (s - b);
  }
};

// Squared distance from (px, pz) to the road point at x.
inline double dist2(const Cleat& c, double x, double px, double pz) {
  const double dx = x - px, dz = c.height(x) - pz;
  return dx * dx + dz * dz;
}

// Closest point on one ramp [x0, x0 + b] to (px, pz): coarse scan, then a
// safeguarded Newton iteration on d/dx of the squared distance inside the
// bracket around the best sample (bisection when Newton leaves it).
double ramp_closest(const Cleat& c, double x0, double px, double pz, double* best_x) {
  const int n_scan = 8;
  double bx = x0, bd = dist2(c, x0, px, pz);
  const double step = c.b / n_scan;
  for (int i = 1; i <= n_scan; ++i) {
    const double x = x0 + i * step;
    const double d = dist2(c, x, px, pz);
    if (d < bd) { bd = d; bx = x; }
  }
  const double w = kPi / c.b, a = 0.5 * c.h;
  const bool rising = x0 == c.xc;
  // derivative of 0.5 * squared distance and its derivative, on the ramp
  auto grad = [&](double x, double* g2) {
    const double u = rising ? (x - x0) : (c.b - (x - x0));
    const double sn = std::sin(w * u), cs = std::cos(w * u);
    const double h = a * (1.0 - cs);
    const double hp = (rising ? 1.0 : -1.0) * a * w * sn;
    const double hpp = a * w * w * cs;
    *g2 = 1.0 + hp * hp + (h - pz) * hpp;
    return (x - px) + (h - pz) * hp;
  };
  double lo = std::max(x0, bx - step), hi = std::min(x0 + c.b, bx + step);
  double dummy;
  double glo = grad(lo, &dummy), ghi = grad(hi, &dummy);
  if (glo < 0.0 && ghi > 0.0) {            // an interior minimum is bracketed
    double x = bx;
    for (int it = 0; it < 30; ++it) {
      double g2;
      const double g = grad(x, &g2);
      if (g < 0.0) lo = x; else hi = x;
      double xn = (g2 > 0.0) ? x - g / g2 : 0.5 * (lo + hi);
      if (!(xn > lo && xn < hi)) xn = 0.5 * (lo + hi);
      if (std::fabs(xn - x) < 1e-13) { x = xn; break; }
      x = xn;
    }
    const double d = dist2(c, x, px, pz);
    if (d < bd) { bd = d; bx = x; }
  }
  *best_x = bx;
  return bd;
}

// Squared distance from a point to a box (lower bound for the ramp search).
inline double box_dist2(double px, double pz, double x0, double x1, double z0, double z1) {
  const double dx = px < x0 ? x0 - px : (px > x1 ? px - x1 : 0.0);
  const double dz = pz < z0 ? z0 - pz : (pz > z1 ? pz - z1 : 0.0);
  return dx * dx + dz * dz;
}

// Rigid disc: closest road point to the wheel centre (px, pz).
// Returns the distance and the unit normal (road -> centre).
double disc_contact(const Cleat& c, double px, double pz, double* nx, double* nz) {
  const double xa = c.xc, xb = c.xc + c.b, xd = c.xc + c.len - c.b, xe = c.xc + c.len;
  // flat road before and after the cleat
  double cx = std::min(px, xa), cz = 0.0;
  double best = (px - cx) * (px - cx) + pz * pz;
  {
    const double x = std::max(px, xe);
    const double d = (px - x) * (px - x) + pz * pz;
    if (d < best) { best = d; cx = x; cz = 0.0; }
  }
  // cleat top
  if (xd > xb) {
    const double x = std::min(std::max(px, xb), xd);
    const double d = (px - x) * (px - x) + (pz - c.h) * (pz - c.h);
    if (d < best) { best = d; cx = x; cz = c.h; }
  }
  // ramps (only when they could be closer)
  const double ramp_x0[2] = {xa, xd};
  for (int r = 0; r < 2; ++r) {
    if (box_dist2(px, pz, ramp_x0[r], ramp_x0[r] + c.b, 0.0, c.h) >= best) continue;
    double x;
    const double d = ramp_closest(c, ramp_x0[r], px, pz, &x);
    if (d < best) { best = d; cx = x; cz = c.height(x); }
  }
  const double dist = std::sqrt(best);
  if (dist > 0.0) {
    *nx = (px - cx) / dist;
    *nz = (pz - cz) / dist;
  } else {
    *nx = 0.0;
    *nz = 1.0;
  }
  return dist;
}

// Spring part of the normal force for deflection rho > 0.
inline double spring_force(const TyreSettings& s, double k, double rho) {
  double f;
  if (s.model == 0) {
    f = k * rho;
  } else {
    const double x = rho / s.r0;
    const double qfz1 = k * s.r0 / s.fz0;
    const double sv = 1.0 + s.qv2 * s.speed / s.v0;   // |Omega| R0 / V0 with Omega = V / R0
    f = sv * ((qfz1 + s.qfz3 * s.camber * s.camber) * x + s.qfz2 * x * x) *
        (1.0 + s.qpfz1 * s.dpi) * s.fz0;
  }
  if (s.bottom_stiffness > 0.0 && rho > s.bottom_deflection) {
    f += s.bottom_stiffness * (rho - s.bottom_deflection);
  }
  return f;
}

// Vertical force on the wheel at time t for centre height z, velocity w;
// `half_patch` is the half-length of the contact patch (patch contact only).
inline double vertical_force(const TyreSettings& s, const Cleat& cl, double k, double c,
                             double half_patch, double t, double z, double w) {
  const double x = s.speed * t;
  double rho, rhodot, nz = 1.0;
  if (s.contact == 0) {
    rho = s.r0 - (z - cl.height(x));
    rhodot = -w + s.speed * cl.slope(x);
  } else if (s.contact == 2) {
    // uniform pressure over [x - a, x + a]: the road height the tyre feels is
    // the patch mean, and its rate the difference of the two patch ends
    const double a = half_patch;
    const double mean_height = (cl.area(x + a) - cl.area(x - a)) / (2.0 * a);
    rho = s.r0 - (z - mean_height);
    rhodot = -w + s.speed * (cl.height(x + a) - cl.height(x - a)) / (2.0 * a);
  } else {
    double nx;
    const double d = disc_contact(cl, x, z, &nx, &nz);
    rho = s.r0 - d;
    rhodot = -(nx * s.speed + nz * w);
  }
  if (rho <= 0.0) return 0.0;
  const double fn = spring_force(s, k, rho) + c * rhodot;
  return fn > 0.0 ? fn * nz : 0.0;
}

// Static deflection: spring_force(rho0) = load (bisection; monotone law).
double static_deflection(const TyreSettings& s, double k) {
  double lo = 0.0, hi = s.r0;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (spring_force(s, k, mid) < s.load) lo = mid; else hi = mid;
    if (hi - lo < 1e-15) break;
  }
  return 0.5 * (lo + hi);
}

// Half-length of the contact patch: half the given patch length, or half the
// chord that the flat road cuts from the unloaded tyre (radius R0) at its
// static deflection rho0, sqrt(2 R0 rho0 - rho0^2).
double patch_half_length(const TyreSettings& s, double k) {
  if (s.patch_length > 0.0) return 0.5 * s.patch_length;
  const double rho0 = static_deflection(s, k);
  return std::sqrt(rho0 * (2.0 * s.r0 - rho0));
}

void simulate(const TyreSettings& s, const Cleat& cl, double k, double c, double* out) {
  const double dt = s.sample_interval / s.steps_per_sample;
  const double m = s.mass;
  const double a = s.contact == 2 ? patch_half_length(s, k) : 0.0;
  double z = s.r0 - static_deflection(s, k), w = 0.0, t = 0.0;
  double f_now = vertical_force(s, cl, k, c, a, t, z, w);
  for (int j = 0; j < s.n_samples; ++j) {
    double acc = 0.0;
    for (int i = 0; i < s.steps_per_sample; ++i) {
      const double k1z = w, k1w = (f_now - s.load) / m;
      const double z2 = z + 0.5 * dt * k1z, w2 = w + 0.5 * dt * k1w;
      const double k2z = w2, k2w = (vertical_force(s, cl, k, c, a, t + 0.5 * dt, z2, w2) - s.load) / m;
      const double z3 = z + 0.5 * dt * k2z, w3 = w + 0.5 * dt * k2w;
      const double k3z = w3, k3w = (vertical_force(s, cl, k, c, a, t + 0.5 * dt, z3, w3) - s.load) / m;
      const double z4 = z + dt * k3z, w4 = w + dt * k3w;
      const double k4z = w4, k4w = (vertical_force(s, cl, k, c, a, t + dt, z4, w4) - s.load) / m;
      z += dt / 6.0 * (k1z + 2.0 * k2z + 2.0 * k3z + k4z);
      w += dt / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w);
      t = (static_cast<double>(j) * s.steps_per_sample + i + 1) * dt;
      const double f_next = vertical_force(s, cl, k, c, a, t, z, w);
      acc += 0.5 * (f_now + f_next);   // trapezoid over the step
      f_now = f_next;
    }
    out[j] = s.sample_mean ? acc / s.steps_per_sample : f_now;
  }
}

double get_num(const Rcpp::List& l, const char* name) {
  return Rcpp::as<double>(l[name]);
}

}  // namespace

// par: N x 2 matrix of (k [N/m], c [N s/m]); heights [m]; settings: named list.
// Returns N x (length(heights) * n_samples), blocks by height.
// Unpacks the settings list built by tyre_settings() in R.
static TyreSettings read_settings(const Rcpp::List& settings) {
  TyreSettings s;
  s.model = Rcpp::as<int>(settings["model"]);
  s.contact = Rcpp::as<int>(settings["contact"]);
  s.load = get_num(settings, "load");
  s.speed = get_num(settings, "speed");
  s.mass = get_num(settings, "mass");
  s.r0 = get_num(settings, "r0");
  s.fz0 = get_num(settings, "fz0");
  s.qfz2 = get_num(settings, "qfz2");
  s.qfz3 = get_num(settings, "qfz3");
  s.qpfz1 = get_num(settings, "qpfz1");
  s.qv2 = get_num(settings, "qv2");
  s.v0 = get_num(settings, "v0");
  s.camber = get_num(settings, "camber");
  s.dpi = get_num(settings, "dpi");
  s.cleat_length = get_num(settings, "cleat_length");
  s.edge_length = get_num(settings, "edge_length");
  s.t_cleat = get_num(settings, "t_cleat");
  s.n_samples = Rcpp::as<int>(settings["n_samples"]);
  s.steps_per_sample = Rcpp::as<int>(settings["steps_per_sample"]);
  s.sample_interval = get_num(settings, "sample_interval");
  s.sample_mean = Rcpp::as<bool>(settings["sample_mean"]);
  s.bottom_stiffness = get_num(settings, "bottom_stiffness");
  s.bottom_deflection = get_num(settings, "bottom_deflection");
  s.patch_length = get_num(settings, "patch_length");
  return s;
}

// [[Rcpp::export]]
arma::mat tyre_sim_cpp(const arma::mat& par, const arma::vec& heights,
                       const Rcpp::List& settings) {
  const TyreSettings s = read_settings(settings);

  const arma::uword nrun = par.n_rows, nh = heights.n_elem;
  const arma::uword ns = static_cast<arma::uword>(s.n_samples);
  arma::mat out(nrun, nh * ns);
  std::vector<double> buf(ns);
  for (arma::uword h = 0; h < nh; ++h) {
    Cleat cl;
    cl.xc = s.speed * s.t_cleat;
    cl.len = s.cleat_length;
    cl.b = s.edge_length;
    cl.h = heights(h);
    for (arma::uword r = 0; r < nrun; ++r) {
      if (r % 16 == 0) Rcpp::checkUserInterrupt();
      simulate(s, cl, par(r, 0), par(r, 1), buf.data());
      for (arma::uword j = 0; j < ns; ++j) out(r, h * ns + j) = buf[j];
    }
  }
  return out;
}

// Static deflection [m] for each stiffness k [N/m] (used by the R side and tests).
// [[Rcpp::export]]
arma::vec tyre_static_deflection_cpp(const arma::vec& k, const Rcpp::List& settings) {
  const TyreSettings s = read_settings(settings);
  arma::vec out(k.n_elem);
  for (arma::uword i = 0; i < k.n_elem; ++i) out(i) = static_deflection(s, k(i));
  return out;
}

// Contact-patch length [m] for each stiffness k [N/m] (patch contact).
// [[Rcpp::export]]
arma::vec tyre_patch_length_cpp(const arma::vec& k, const Rcpp::List& settings) {
  const TyreSettings s = read_settings(settings);
  arma::vec out(k.n_elem);
  for (arma::uword i = 0; i < k.n_elem; ++i) out(i) = 2.0 * patch_half_length(s, k(i));
  return out;
}
