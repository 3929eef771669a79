// Vertical dynamics of one wheel on a constant-load tyre rig rolling over a
// cleat (Stewart 2023, chapter 5 stand-in).  Fixed-step RK4 on the wheel-centre
// height with the contact events (touch-down, lift-off, the disc's contact
// point jumping to the cleat) located within the step; Fiala or
// PAC2002-style vertical force; point-follower, rigid-disc or
// rectangular-patch (uniform pressure) contact.
//
// All inputs are SI and validated on the R side (R/standin-tyre.R).

#include <RcppArmadillo.h>
#include <cmath>
#include <algorithm>
#include <limits>

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

// Rigid disc, split in two: the nearest point of the flat road (before and
// after the cleat) and the nearest point of the cleat (ramps and top).  The
// disc's contact point is the nearer of the two.  Each part's nearest point
// moves continuously with the wheel centre (the cleat's top corners are
// convex, the flat road is flat); the contact point jumps from one part to
// the other where both are equally near, which is a contact event of its own
// (see simulate()).
struct Nearest { double d, x, z; };

Nearest flat_nearest(const Cleat& c, double px, double pz) {
  const double xa = c.xc, xe = c.xc + c.len;
  double x = std::min(px, xa);
  double best = (px - x) * (px - x) + pz * pz;
  const double xr = std::max(px, xe);
  const double dr = (px - xr) * (px - xr) + pz * pz;
  if (dr < best) { best = dr; x = xr; }
  return Nearest{std::sqrt(best), x, 0.0};
}

// The cleat's nearest point; ramps whose bounding box lies at least `bound`
// away are skipped (the result is then only known to be >= bound, and d is
// returned as bound).
Nearest cleat_nearest(const Cleat& c, double px, double pz, double bound) {
  const double xb = c.xc + c.b, xd = c.xc + c.len - c.b;
  double best = bound * bound, cx = px, cz = c.h;
  bool found = false;
  if (xd > xb) {
    const double x = std::min(std::max(px, xb), xd);
    const double d = (px - x) * (px - x) + (pz - c.h) * (pz - c.h);
    if (d < best) { best = d; cx = x; found = true; }
  }
  const double ramp_x0[2] = {c.xc, xd};
  for (int r = 0; r < 2; ++r) {
    if (box_dist2(px, pz, ramp_x0[r], ramp_x0[r] + c.b, 0.0, c.h) >= best) continue;
    double x;
    const double d = ramp_closest(c, ramp_x0[r], px, pz, &x);
    if (d < best) { best = d; cx = x; cz = c.height(x); found = true; }
  }
  if (!found) return Nearest{bound, px, 0.0};
  return Nearest{std::sqrt(best), cx, cz};
}

// Spring part of the normal force for deflection rho (also for rho <= 0,
// where it is the smooth continuation the event location steps through);
// `bottomed` adds the rim-bottoming spring.
inline double spring_force(const TyreSettings& s, double k, double rho, bool bottomed) {
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
  if (bottomed) f += s.bottom_stiffness * (rho - s.bottom_deflection);
  return f;
}

// Static deflection: spring_force(rho0) = load (bisection; monotone law).
double static_deflection(const TyreSettings& s, double k) {
  double lo = 0.0, hi = s.r0;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    const bool bottomed = s.bottom_stiffness > 0.0 && mid > s.bottom_deflection;
    if (spring_force(s, k, mid, bottomed) < s.load) lo = mid; else hi = mid;
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

// Which branch of the piecewise force law holds.  The force is smooth within
// a mode and changes its formula where one of these switches: the tyre
// touches or leaves the road (rho = 0, where the damping term makes the force
// jump), the normal force would turn into tension (fn = 0), the rim bottoms
// (rho = bottom deflection), or the disc's contact point jumps between the
// flat road and the cleat.  A fixed step that ran across such a switch would
// place it at a stage evaluation, and a tiny change of k or c would move it
// by a whole stage: the outputs, and the likelihood, would jump between
// neighbouring parameter values.
struct Mode { bool contact, pushing, bottomed, on_cleat; };

// Deflection, its rate, the vertical share of the normal, and the switching
// values, at time t for centre height z and velocity w.
struct Contact { double rho, rhodot, nz, gap_switch; };

class Wheel {
 public:
  Wheel(const TyreSettings& s, const Cleat& cl, double k, double c)
      : s_(s), cl_(cl), k_(k), c_(c), a_(s.contact == 2 ? patch_half_length(s, k) : 0.0) {}

  // Contact geometry on the mode's branch; with `both`, also the sign of the
  // disc's switch (flat distance minus cleat distance, > 0: the cleat is nearer).
  Contact geometry(double t, double z, double w, bool on_cleat, bool both) const {
    const double x = s_.speed * t;
    Contact g{0.0, 0.0, 1.0, 0.0};
    if (s_.contact == 0) {
      g.rho = s_.r0 - (z - cl_.height(x));
      g.rhodot = -w + s_.speed * cl_.slope(x);
    } else if (s_.contact == 2) {
      // uniform pressure over [x - a, x + a]: the road height the tyre feels is
      // the patch mean, and its rate the difference of the two patch ends
      const double a = a_;
      const double mean_height = (cl_.area(x + a) - cl_.area(x - a)) / (2.0 * a);
      g.rho = s_.r0 - (z - mean_height);
      g.rhodot = -w + s_.speed * (cl_.height(x + a) - cl_.height(x - a)) / (2.0 * a);
    } else {
      const Nearest f = flat_nearest(cl_, x, z);
      Nearest n = f;
      if (on_cleat) {
        n = cleat_nearest(cl_, x, z, std::numeric_limits<double>::infinity());
        if (both) g.gap_switch = f.d - n.d;
      } else if (both) {
        g.gap_switch = f.d - cleat_nearest(cl_, x, z, f.d).d;   // <= 0 when pruned
      }
      double nx = 0.0;
      if (n.d > 0.0) { nx = (x - n.x) / n.d; g.nz = (z - n.z) / n.d; }
      g.rho = s_.r0 - n.d;
      g.rhodot = -(nx * s_.speed + g.nz * w);
    }
    return g;
  }

  double normal_force(const Contact& g, bool bottomed) const {
    return spring_force(s_, k_, g.rho, bottomed) + c_ * g.rhodot;
  }

  // Vertical force with the mode frozen (smooth in t, z, w).
  double force(double t, double z, double w, const Mode& m) const {
    if (!m.contact || !m.pushing) return 0.0;
    const Contact g = geometry(t, z, w, m.on_cleat, false);
    return normal_force(g, m.bottomed) * g.nz;
  }

  // The mode that holds at (t, z, w).
  Mode mode_at(double t, double z, double w) const {
    Mode m{false, false, false, false};
    if (s_.contact == 1) m.on_cleat = geometry(t, z, w, false, true).gap_switch > 0.0;
    const Contact g = geometry(t, z, w, m.on_cleat, false);
    m.contact = g.rho > 0.0;
    m.bottomed = s_.bottom_stiffness > 0.0 && g.rho > s_.bottom_deflection;
    m.pushing = normal_force(g, m.bottomed) > 0.0;
    return m;
  }

  // Does the mode m still hold at (t, z, w)?  If so, also the force there.
  bool holds(double t, double z, double w, const Mode& m, double* f) const {
    const Contact g = geometry(t, z, w, m.on_cleat, true);
    if (s_.contact == 1 && (g.gap_switch > 0.0) != m.on_cleat) return false;
    if ((g.rho > 0.0) != m.contact) return false;
    if (s_.bottom_stiffness > 0.0 && (g.rho > s_.bottom_deflection) != m.bottomed) return false;
    if (!m.contact) { *f = 0.0; return true; }
    const double fn = normal_force(g, m.bottomed);
    if ((fn > 0.0) != m.pushing) return false;
    *f = m.pushing ? fn * g.nz : 0.0;
    return true;
  }

  // One classical RK4 step of size h from (t, z, w) with the mode frozen;
  // f0 is the force at the start.  *impulse is the step's integral of Fz by
  // the same quadrature that updates w (so it is >= 0, as Fz is).
  void rk4(double t, double z, double w, double f0, double h, const Mode& m,
           double* z1, double* w1, double* impulse) const {
    const double mass = s_.mass, load = s_.load;
    const double k1z = w, k1w = (f0 - load) / mass;
    const double z2 = z + 0.5 * h * k1z, w2 = w + 0.5 * h * k1w;
    const double f2 = force(t + 0.5 * h, z2, w2, m);
    const double k2z = w2, k2w = (f2 - load) / mass;
    const double z3 = z + 0.5 * h * k2z, w3 = w + 0.5 * h * k2w;
    const double f3 = force(t + 0.5 * h, z3, w3, m);
    const double k3z = w3, k3w = (f3 - load) / mass;
    const double z4 = z + h * k3z, w4 = w + h * k3w;
    const double f4 = force(t + h, z4, w4, m);
    const double k4z = w4, k4w = (f4 - load) / mass;
    *z1 = z + h / 6.0 * (k1z + 2.0 * k2z + 2.0 * k3z + k4z);
    *w1 = w + h / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w);
    *impulse = h / 6.0 * (f0 + 2.0 * f2 + 2.0 * f3 + f4);
  }

 private:
  const TyreSettings& s_;
  const Cleat& cl_;
  double k_, c_, a_;
};

// Fixed-step RK4 with event location.  Each step is tried with the mode
// frozen; if the mode no longer holds at its end, bisection on the step
// length finds where it stops holding (to about 1e-12 of a step, i.e. 1e-17 s
// at the default step), the step is taken to just past that point, the mode
// switched and the rest of the step integrated in the new mode.  The switch
// times then move smoothly with k and c, and so do the outputs.
//
// Outputs: "mean" is the mean force over the sample interval, the impulse
// the integrator actually applied (m (w1 - w0) = int (Fz - load) dt) over its
// length; "instant" is Fz at the sample time.
void simulate(const TyreSettings& s, const Cleat& cl, double k, double c, double* out) {
  const Wheel wheel(s, cl, k, c);
  const double dt = s.sample_interval / s.steps_per_sample;
  double z = s.r0 - static_deflection(s, k), w = 0.0;
  Mode mode = wheel.mode_at(0.0, z, w);
  double f = wheel.force(0.0, z, w, mode);
  const int max_events = 16;   // per step; beyond that the step is accepted as tried
  for (int j = 0; j < s.n_samples; ++j) {
    double impulse = 0.0;
    for (int i = 0; i < s.steps_per_sample; ++i) {
      const double t_step = (static_cast<double>(j) * s.steps_per_sample + i) * dt;
      double done = 0.0;   // time integrated within this step
      for (int events = 0; ; ++events) {
        const double t0 = t_step + done, h = dt - done;
        double z1, w1, f1, p1;
        wheel.rk4(t0, z, w, f, h, mode, &z1, &w1, &p1);
        if (events >= max_events || wheel.holds(t_step + dt, z1, w1, mode, &f1)) {
          if (events >= max_events) {
            mode = wheel.mode_at(t_step + dt, z1, w1);
            f1 = wheel.force(t_step + dt, z1, w1, mode);
          }
          z = z1; w = w1; f = f1; impulse += p1;
          break;
        }
        // bisection: the mode holds at lo and not at hi
        double lo = 0.0, hi = h, zh = z1, wh = w1, ph = p1;
        while (hi - lo > 1e-12 * dt) {
          const double mid = 0.5 * (lo + hi);
          double zm, wm, fm, pm;
          wheel.rk4(t0, z, w, f, mid, mode, &zm, &wm, &pm);
          if (wheel.holds(t0 + mid, zm, wm, mode, &fm)) {
            lo = mid;
          } else {
            hi = mid; zh = zm; wh = wm; ph = pm;
          }
        }
        z = zh; w = wh; impulse += ph; done += hi;
        mode = wheel.mode_at(t0 + hi, z, w);
        f = wheel.force(t0 + hi, z, w, mode);
        if (dt - done <= 1e-12 * dt) break;
      }
    }
    out[j] = s.sample_mean ? impulse / s.sample_interval : f;
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
