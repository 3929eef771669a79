// One chain of the Griddy Gibbs sampler over a precomputed table of quadratic
// forms C (runs x correlation grid points). Each iteration draws the library
// run theta, the precision tau and the correlation grid point.
//
// update = "thesis" (Appendix A.3): theta | tau, grid; tau | theta, grid;
//   grid | theta, tau.
// update = "collapsed": theta | grid and grid | theta with tau integrated out
//   (Gamma-normal), then tau | theta, grid. Given the grid point, the
//   collapsed conditional of theta does not depend on the chain's state, so
//   its CDF (one per grid point) is computed once, before any chain runs.
//
// Both theta draws run over the runs sorted by C_ig, whose weights fall
// monotonically with C_ig, and keep only the head of that list: the runs
// left out hold less than `tol` of the total weight (see log_budget() in
// inverse_cdf.h), so a draw costs the head's length, not N.
#include <RcppArmadillo.h>
#include <algorithm>
#include <numeric>
#include <unordered_map>
#include <vector>
#include "grid_posterior.h"
#include "inverse_cdf.h"
#include "parallel_waves.h"
#include "radix_order.h"

namespace griddy {

// Everything a chain needs besides C and its tables, read once from R's list.
struct SamplerOptions {
  bool collapsed;
  double shape_post;     // a + n/2
  double rate;           // b
  double tol;            // truncation of the theta draws
  int n_iter, first_iter, burn_in, thin;
  // R's vectors, held without a copy (a chain runs in many pieces, and
  // log_prior_run has N elements)
  Rcpp::NumericVector logdet;          // log|R_g| per grid point
  Rcpp::NumericVector log_prior_run;   // log pi_i per run
  Rcpp::NumericVector log_prior_grid;  // log pi_g per grid point
};

SamplerOptions read_options(const Rcpp::List& o, const arma::mat& C) {
  SamplerOptions s;
  s.collapsed = Rcpp::as<std::string>(o["update"]) == "collapsed";
  s.shape_post = Rcpp::as<double>(o["shape"]) + 0.5 * Rcpp::as<double>(o["n_obs"]);
  s.rate = Rcpp::as<double>(o["rate"]);
  s.tol = Rcpp::as<double>(o["tol"]);
  s.n_iter = Rcpp::as<int>(o["n_iter"]);
  s.first_iter = Rcpp::as<int>(o["first_iter"]);
  s.burn_in = Rcpp::as<int>(o["burn_in"]);
  s.thin = Rcpp::as<int>(o["thin"]);
  s.logdet = o["logdet"];
  s.log_prior_run = o["log_prior_run"];
  s.log_prior_grid = o["log_prior_grid"];
  if (static_cast<arma::uword>(s.log_prior_run.size()) != C.n_rows ||
      static_cast<arma::uword>(s.logdet.size()) != C.n_cols ||
      static_cast<arma::uword>(s.log_prior_grid.size()) != C.n_cols) {
    Rcpp::stop("gibbs_chain: C is %d x %d but there are %d run priors, %d grid priors and "
               "%d log-determinants", static_cast<int>(C.n_rows), static_cast<int>(C.n_cols),
               static_cast<int>(s.log_prior_run.size()),
               static_cast<int>(s.log_prior_grid.size()), static_cast<int>(s.logdet.size()));
  }
  if (s.thin < 1 || s.n_iter < 0) Rcpp::stop("gibbs_chain: thin must be >= 1, n_iter >= 0");
  return s;
}

// The collapsed theta | grid point draws: per grid point, the head of the runs
// sorted by C (0-based run numbers) and their cumulative weights.
struct CollapsedHeads {
  Rcpp::IntegerVector start, run;
  Rcpp::NumericVector cdf;
};

// Every grid point's runs in increasing order of C, for the thesis update.
struct SortedRuns {
  Rcpp::IntegerMatrix order;
  std::vector<double> budget;  // log-weight budget of the truncation per grid point
};

// The chain's state and what it accumulates.
struct ChainState {
  arma::uword run = 0, grid = 0;
  double tau = 1.0;
  double head_total = 0.0;
};

// theta | grid point, tau integrated out: a binary search in the precomputed CDF.
void draw_theta_collapsed(const CollapsedHeads& heads, ChainState& st) {
  const int from = heads.start[st.grid];
  const arma::uword len = heads.start[st.grid + 1] - from;
  st.run = heads.run[from + draw_from_cdf(&heads.cdf[from], len)];
  st.head_total += len;
}

// theta | tau, grid point (thesis): weights pi_i exp(-tau C_ig / 2) over the
// head of the sorted runs.
void draw_theta_given_tau(const arma::mat& C, const SortedRuns& sorted,
                          const SamplerOptions& o, bool flat_runs, std::vector<double>& log_w,
                          std::vector<double>& work, ChainState& st) {
  const arma::uword n_runs = C.n_rows;
  const double* c = C.colptr(st.grid);
  const int* order = &sorted.order[st.grid * n_runs];
  const double c_min = c[order[0]];
  const arma::uword len = head_length(c, order, n_runs,
                                      c_min + 2.0 * sorted.budget[st.grid] / st.tau);
  for (arma::uword j = 0; j < len; ++j) {
    log_w[j] = given_tau_log_fit(c[order[j]] - c_min, st.tau) +
      (flat_runs ? 0.0 : o.log_prior_run[order[j]]);
  }
  st.run = order[draw_from_log_weights(log_w.data(), len, work.data())];
  st.head_total += len;
}

// Rows of G numbers per run, kept for the runs a chain revisits (they are
// few: the posterior's): the collapsed update's CDF over grid points, which
// depends on the run only, or the thesis update's row of C, whose G entries
// lie N apart in memory. At most `max_doubles` are kept; a run that does not
// fit is computed each time.
class RunRows {
 public:
  RunRows(arma::uword n_grid, std::size_t max_doubles)
      : n_grid_(n_grid), max_rows_(max_doubles / std::max<arma::uword>(n_grid, 1)) {}
  const double* find(arma::uword run) const {
    const auto it = at_.find(run);
    return it == at_.end() ? nullptr : &rows_[it->second];
  }
  // room for a new row (valid until the next add()), or null when full
  double* add(arma::uword run) {
    if (at_.size() >= max_rows_) return nullptr;
    at_[run] = rows_.size();
    rows_.resize(rows_.size() + n_grid_);
    return &rows_[rows_.size() - n_grid_];
  }

 private:
  arma::uword n_grid_;
  std::size_t max_rows_;
  std::unordered_map<arma::uword, std::size_t> at_;
  std::vector<double> rows_;
};

constexpr std::size_t kRunRowsMax = std::size_t{1} << 22;  // 32 MB

// grid point | theta (tau integrated out when collapsed, else given tau).
// The draw is the same with or without the rows kept: the same weights, in
// the same order.
void draw_grid(const arma::mat& C, const SamplerOptions& o, RunRows& rows,
               std::vector<double>& log_w, std::vector<double>& work, ChainState& st) {
  const arma::uword n_grid = C.n_cols;
  if (n_grid < 2) return;
  const double* kept = rows.find(st.run);
  if (o.collapsed && kept) {
    st.grid = draw_from_cdf(kept, n_grid);
    return;
  }
  double* row = kept ? nullptr : rows.add(st.run);
  if (!o.collapsed && row) {
    for (arma::uword g = 0; g < n_grid; ++g) row[g] = C(st.run, g);
    kept = row;
  }
  for (arma::uword g = 0; g < n_grid; ++g) {
    const double c = kept ? kept[g] : C(st.run, g);
    const double fit = o.collapsed ? collapsed_log_fit(c, o.shape_post, o.rate)
                                   : given_tau_log_fit(c, st.tau);
    log_w[g] = grid_log_weight(o.log_prior_grid[g], o.logdet[g]) + fit;
  }
  double* cdf = (o.collapsed && row) ? row : work.data();
  cumulative_weights(log_w.data(), n_grid, cdf);
  st.grid = draw_from_cdf(cdf, n_grid);
}

// tau | theta, grid point ~ Gamma(a + n/2, rate b + C/2).
void draw_tau(const arma::mat& C, const SamplerOptions& o, ChainState& st) {
  st.tau = R::rgamma(o.shape_post, 1.0 / (o.rate + 0.5 * C(st.run, st.grid)));
}

// Whether a column of C is free of NA, NaN and Inf.
bool column_finite(const double* c, arma::uword n) {
  bool finite = true;
  for (arma::uword i = 0; i < n; ++i) finite = finite && std::isfinite(c[i]);
  return finite;
}

// Every column's run order (0-based), for the thesis update, whose weights
// exp(-tau C_ig / 2) change with tau: the head is found per draw. Columns
// are sorted on `threads` threads (parallel_waves.h).
Rcpp::IntegerMatrix run_order(const arma::mat& C, int threads) {
  Rcpp::IntegerMatrix order = Rcpp::no_init(C.n_rows, C.n_cols);  // every entry written
  int* out = order.begin();
  threads = usable_threads(threads);
  std::vector<RadixOrder> sorters(threads);
  std::vector<char> finite(C.n_cols, 1);
  const long long wave = std::max<long long>(threads, 1e8 / std::max<arma::uword>(C.n_rows, 1));
  parallel_waves(C.n_cols, wave, threads, [&](long long g, int thread) {
    const double* c = C.colptr(g);
    finite[g] = column_finite(c, C.n_rows);
    if (finite[g]) sorters[thread](c, static_cast<int>(C.n_rows), out + g * C.n_rows);
  });
  if (std::find(finite.begin(), finite.end(), 0) != finite.end()) {
    Rcpp::stop("run_order: C holds NA, NaN or Inf");
  }
  return order;
}

// The head of one column of C for the collapsed theta | grid point draw (see
// collapsed_heads()): its runs (0-based, by increasing C) and cumulative
// weights.
struct ColumnHead {
  std::vector<int> run;
  std::vector<double> cdf;
  bool finite = true;
};

void column_head(const double* c, const arma::vec& log_prior_run, double lp_max,
                 double shape_post, double rate, double tol, ColumnHead& out) {
  const arma::uword n = log_prior_run.n_elem;
  out.finite = column_finite(c, n);
  if (!out.finite) return;
  const arma::uword first = std::min_element(c, c + n) - c;
  const double budget = log_budget(n, tol, lp_max, log_prior_run[first]);
  // (b + C/2) / (b + C_min/2) > exp(budget / shape_post) leaves the head
  const double cut = 2.0 * ((rate + 0.5 * c[first]) * std::exp(budget / shape_post) - rate);
  for (arma::uword i = 0; i < n; ++i) {
    if (!(c[i] > cut)) out.run.push_back(static_cast<int>(i));
  }
  std::stable_sort(out.run.begin(), out.run.end(), [c](int a, int b) { return c[a] < c[b]; });
  const arma::uword k = out.run.size();
  std::vector<double> log_w(k);
  for (arma::uword j = 0; j < k; ++j) {
    log_w[j] = log_prior_run[out.run[j]] + collapsed_log_fit(c[out.run[j]], shape_post, rate);
  }
  out.cdf.resize(k);
  cumulative_weights(log_w.data(), k, out.cdf.data());
}

// The collapsed theta | grid point draw of every grid point g: the head of the
// runs sorted by C_ig (those whose weight pi_i (b + C_ig / 2)^-(a + n/2) can
// exceed tol / N of the first run's) and their cumulative weights, scaled so
// the largest weight is 1. Ragged columns stored end to end: column g is
// positions start[g] to start[g + 1] - 1 of `run` (0-based) and `cdf`.
// Columns are found on `threads` threads (parallel_waves.h), in waves whose
// heads are then appended in column order.
Rcpp::List collapsed_heads(const arma::mat& C, const arma::vec& log_prior_run,
                           double shape_post, double rate, double tol, int threads) {
  const arma::uword n = C.n_rows;
  if (log_prior_run.n_elem != n || n == 0) {
    Rcpp::stop("collapsed_heads: C has %d rows but there are %d run priors",
               static_cast<int>(n), static_cast<int>(log_prior_run.n_elem));
  }
  const double lp_max = log_prior_run.max();
  std::vector<int> start(C.n_cols + 1, 0), runs;
  std::vector<double> cdf;
  const long long wave = std::max<long long>(usable_threads(threads), 1e8 / n);
  std::vector<ColumnHead> heads;
  for (arma::uword g0 = 0; g0 < C.n_cols; g0 += wave) {
    const arma::uword g1 = std::min<arma::uword>(C.n_cols, g0 + wave);
    heads.assign(g1 - g0, ColumnHead());
    parallel_waves(g1 - g0, g1 - g0, threads, [&](long long k, int) {
      column_head(C.colptr(g0 + k), log_prior_run, lp_max, shape_post, rate, tol, heads[k]);
    });
    for (arma::uword g = g0; g < g1; ++g) {
      const ColumnHead& h = heads[g - g0];
      if (!h.finite) Rcpp::stop("collapsed_heads: C holds NA, NaN or Inf");
      runs.insert(runs.end(), h.run.begin(), h.run.end());
      cdf.insert(cdf.end(), h.cdf.begin(), h.cdf.end());
      start[g + 1] = static_cast<int>(runs.size());
    }
  }
  return Rcpp::List::create(Rcpp::Named("start") = Rcpp::wrap(start),
                            Rcpp::Named("run") = Rcpp::wrap(runs),
                            Rcpp::Named("cdf") = Rcpp::wrap(cdf));
}

// Runs `options$n_iter` iterations from `state` (grid point 0-based, tau) and
// returns the kept draws (1-based run and grid point), the final state and
// the summed head lengths. `tables` holds what the update needs: `heads`
// (from collapsed_heads_cpp) or `order` (from run_order_cpp).
Rcpp::List gibbs_chain(const arma::mat& C, const Rcpp::List& tables,
                       const Rcpp::List& options, int grid_start, double tau_start) {
  const SamplerOptions o = read_options(options, C);
  const arma::uword n_runs = C.n_rows;
  const arma::uword n_grid = C.n_cols;
  if (grid_start < 0 || static_cast<arma::uword>(grid_start) >= n_grid) {
    Rcpp::stop("gibbs_chain: the starting grid point %d is not in 0..%d", grid_start,
               static_cast<int>(n_grid) - 1);
  }

  CollapsedHeads heads;
  SortedRuns sorted;
  if (o.collapsed) {
    const Rcpp::List h = tables["heads"];
    heads.start = h["start"];
    heads.run = h["run"];
    heads.cdf = h["cdf"];
    if (heads.start.size() != static_cast<R_xlen_t>(n_grid) + 1) {
      Rcpp::stop("gibbs_chain: heads for %d grid points, C has %d",
                 static_cast<int>(heads.start.size()) - 1, static_cast<int>(n_grid));
    }
  } else {
    sorted.order = Rcpp::as<Rcpp::IntegerMatrix>(tables["order"]);
    if (static_cast<arma::uword>(sorted.order.nrow()) != n_runs ||
        static_cast<arma::uword>(sorted.order.ncol()) != n_grid) {
      Rcpp::stop("gibbs_chain: run order is %d x %d, C is %d x %d", sorted.order.nrow(),
                 sorted.order.ncol(), static_cast<int>(n_runs), static_cast<int>(n_grid));
    }
    const double lp_max = *std::max_element(o.log_prior_run.begin(), o.log_prior_run.end());
    sorted.budget.resize(n_grid);
    for (arma::uword g = 0; g < n_grid; ++g) {
      sorted.budget[g] = log_budget(n_runs, o.tol, lp_max, o.log_prior_run[sorted.order(0, g)]);
    }
  }
  // the thesis draw skips the run prior when it is flat (O(N) to find out,
  // so only for that update)
  const double lp_first = o.log_prior_run[0];
  const bool flat_runs = !o.collapsed &&
    std::all_of(o.log_prior_run.begin(), o.log_prior_run.end(),
                [lp_first](double v) { return v == lp_first; });

  int n_keep = 0;
  for (int it = o.first_iter; it < o.first_iter + o.n_iter; ++it) {
    if (it > o.burn_in && (it - o.burn_in) % o.thin == 0) ++n_keep;
  }
  Rcpp::IntegerVector run_out(n_keep), grid_out(n_keep);
  Rcpp::NumericVector tau_out(n_keep);

  // log weights over the head of the runs (thesis update) or over the grid
  const arma::uword n_weights = o.collapsed ? n_grid : std::max(n_runs, n_grid);
  std::vector<double> log_w(n_weights), work(n_weights);
  // options$keep_rows (doubles) for tests: 0 keeps none
  RunRows rows(n_grid, options.containsElementNamed("keep_rows") ?
                         Rcpp::as<std::size_t>(options["keep_rows"]) : kRunRowsMax);
  ChainState st;
  st.grid = static_cast<arma::uword>(grid_start);
  st.tau = tau_start;
  int k = 0;
  for (int it = o.first_iter; it < o.first_iter + o.n_iter; ++it) {
    if ((it - o.first_iter) % 256 == 0) Rcpp::checkUserInterrupt();
    if (o.collapsed) {
      draw_theta_collapsed(heads, st);
      draw_grid(C, o, rows, log_w, work, st);
      draw_tau(C, o, st);
    } else {
      draw_theta_given_tau(C, sorted, o, flat_runs, log_w, work, st);
      draw_tau(C, o, st);
      draw_grid(C, o, rows, log_w, work, st);
    }
    if (it > o.burn_in && (it - o.burn_in) % o.thin == 0) {
      run_out[k] = static_cast<int>(st.run) + 1;
      grid_out[k] = static_cast<int>(st.grid) + 1;
      tau_out[k] = st.tau;
      ++k;
    }
  }
  return Rcpp::List::create(Rcpp::Named("run") = run_out,
                            Rcpp::Named("grid_point") = grid_out,
                            Rcpp::Named("tau") = tau_out,
                            Rcpp::Named("grid_state") = static_cast<int>(st.grid),
                            Rcpp::Named("tau_state") = st.tau,
                            Rcpp::Named("head_total") = st.head_total);
}

}  // namespace griddy

// The R entry points. Rcpp attributes declares them at global scope, so they
// only hand R's objects to the functions of namespace griddy above.

// [[Rcpp::export]]
Rcpp::IntegerMatrix run_order_cpp(const arma::mat& C, int threads = 1) {
  return griddy::run_order(C, threads);
}

// [[Rcpp::export]]
Rcpp::List collapsed_heads_cpp(const arma::mat& C, const arma::vec& log_prior_run,
                               double shape_post, double rate, double tol, int threads = 1) {
  return griddy::collapsed_heads(C, log_prior_run, shape_post, rate, tol, threads);
}

// [[Rcpp::export]]
Rcpp::List gibbs_chain_cpp(const arma::mat& C, const Rcpp::List& tables,
                           const Rcpp::List& options, int grid_start, double tau_start) {
  return griddy::gibbs_chain(C, tables, options, grid_start, tau_start);
}
