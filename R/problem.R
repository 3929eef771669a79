# What calibrate() and posterior_exact() share: the validated inputs, the
# correlation setup and the quadratic forms C (runs x correlation grid). A
# griddy_fit is this problem plus the draws, so every function that takes a
# problem also takes a fit.
#
# A problem (class griddy_problem) is made by new_griddy_problem() only;
# its fields:
#
# * library: the library (any backend), with what its misfit table found
#   for these field data kept (an emulated library's noise plug-in,
#   lib_with_plug_in());
# * y_field: the field data in the library's order (cell means for
#   replicates), NA where missing;
# * n_obs: the number of measurements (observed cells plus the replicates'
#   pure-error degrees of freedom);
# * prior: the Gamma(shape, rate) prior on tau. The problem holds it; its
#   setup carries the same object as `fold_prior` (the one copy the
#   quadratic forms read, to fold noise groups and for an emulated
#   library's plug-in), set here when the setup has none;
# * log_prior_run, log_prior_grid: log prior weights of the runs and of the
#   grid points (grid_log_prior());
# * setup: the correlation setup (correlation_setup(); its factors are read
#   through grid_point());
# * grid: the grid as a table (setup_grid_table());
# * C: the quadratic forms, runs x grid points, extra log-determinants
#   folded in (misfit_table());
# * emulation_error: an emulated library's leave-one-out error near the
#   posterior over the noise sd (NULL otherwise), for summary().

calibration_problem <- function(library, field, rho_x, rho_t, prior, x_power,
                                run_weights, noise_groups = NULL, update = NULL,
                                discrepancy = NULL) {
  check_library(library)
  discrepancy <- assert_discrepancy(discrepancy)
  layout <- field_layout(library, field)
  default_prior <- is.null(prior)
  prior <- assert_prior(if (default_prior) thesis_prior() else prior)
  log_prior_run <- log_run_weights(run_weights, library)
  if (!is.null(discrepancy)) {
    discrepancy <- discrepancy_for_data(discrepancy, library, layout$y,
                                        noise_pattern(library, layout, noise_groups, prior))
  }
  # a discrepancy breaks the Kronecker structure: dense factors throughout
  pattern <- noise_pattern(library, layout, noise_groups, prior,
                           dense = !is.null(discrepancy))
  setup <- setup_with_prior(correlation_setup(library, rho_x, rho_t, x_power, pattern,
                                              discrepancy), prior)
  inform_memory(library, n_grid_points(setup), update)
  problem <- new_griddy_problem(library, layout$y, prior, log_prior_run, setup)
  if (default_prior) warn_prior_scale(problem)
  problem
}

# The one constructor of a problem (fields above), from validated parts; `C`
# is the misfit table (misfit_table()'s list, or a matrix already folded).
# refine(), diagnose_gap() and the gap screen build their problems here too.
new_griddy_problem <- function(library, y_field, prior, log_prior_run, setup,
                               C = misfit_table(library, y_field, setup_with_prior(setup, prior),
                                                prior)) {
  setup <- setup_with_prior(setup, prior)
  misfit <- misfit_parts(C)
  C <- misfit$C
  assert_misfit_scale(C, y_field, sum(setup$group_sizes))
  if (prior$rate == 0 && min(C) <= 0) {  # min(): no temporary as large as C
    griddy_abort("A library run reproduces the field data exactly, so with ",
                 "`prior$rate` = 0 its posterior weight is infinite. Use a positive rate.")
  }
  # an emulated library's noise plug-in for these data (emulation.R),
  # kept with it so that what reads its error later agrees with C
  library <- lib_with_plug_in(library, misfit$plug_in)
  structure(
    list(library = library, y_field = y_field, n_obs = sum(setup$group_sizes), prior = prior,
         log_prior_run = log_prior_run, setup = setup, grid = setup_grid_table(library, setup),
         C = C, log_prior_grid = grid_log_prior(setup),
         emulation_error = misfit$emulation_error),
    class = "griddy_problem")
}

# The setup carrying the problem's prior (see the fields above): a setup
# built with a noise pattern has it already, the same object.
setup_with_prior <- function(setup, prior) {
  if (is.null(setup$fold_prior)) setup$fold_prior <- prior
  setup
}

# The prior over correlation grid points: uniform over the distinct
# correlation structures R_g, each structure's mass shared by the grid points
# that give it. (A rho_j = 0 makes R_x the identity whatever the other x
# columns' rho when every setting differs in column j, so a prior uniform
# over grid points would favour independence.)
#
# With a discrepancy, each discrepancy point's prior (discrepancy_points())
# multiplies the prior of the correlation structure.
grid_log_prior <- function(setup) {
  base <- seq_len(length(setup$gx) / max(nrow(setup$discrepancy), 1L))
  key <- paste(setup$x_class[setup$gx[base]], setup$gt[base])
  count <- table(key)[key]
  lp <- as.vector(-log(length(unique(key))) - log(count))
  if (is.null(setup$discrepancy)) return(lp)
  rep(lp, nrow(setup$discrepancy)) + setup$discrepancy$log_prior[setup$gd]
}

# The grid as a table, one row per grid point of `setup`: the correlation
# parameters (grid_table()) and, with a discrepancy, its ratio and length
# scales (columns delta_ratio, delta_length_x, delta_length_t; NA where a
# length does not apply).
setup_grid_table <- function(library, setup) {
  grid <- grid_table(library, list(x = setup$rho_x, t = setup$rho_t))
  disc <- setup$discrepancy
  if (is.null(disc)) return(grid)
  out <- grid[rep(seq_len(nrow(grid)), nrow(disc)), , drop = FALSE]
  out$delta_ratio <- disc$ratio[setup$gd]
  if (lib_n_x(library) > 1L) out$delta_length_x <- disc$length_x[setup$gd]
  if (lib_n_t(library) > 1L) out$delta_length_t <- disc$length_t[setup$gd]
  rownames(out) <- NULL
  out
}

# ---- the noise pattern ----------------------------------------------------------

# What the likelihood needs to know about the field beyond its values (see
# engine.R): which library outputs are observed, the relative sd of
# their values (`sd_mean`, NULL when neither sd nor replicates are given) and
# of one measurement (`sd`, for predict()), the noise group of each library
# output (`group`, indices into `labels`), with the prior that folds the
# groups; and the replicates' pure error (see field_layout()): each group's
# sum of squares `pure_ss` and degrees of freedom `pure_df`, and the
# constant `log_sd_excess` of the log-determinant.
# NULL for complete data with one group, no sd and no replicates (the
# Kronecker case), unless `dense` asks for the pattern anyway.
noise_pattern <- function(library, layout, noise_groups, prior, dense = FALSE) {
  observed <- !is.na(layout$y)
  groups <- noise_group_index(noise_groups, lib_n_x(library), lib_n_t(library))
  if (!dense && all(observed) && is.null(layout$sd_mean) && length(groups$labels) == 1L) {
    return(NULL)
  }
  empty <- setdiff(seq_along(groups$labels), groups$group[observed])
  if (length(empty) > 0L) {
    griddy_abort("Noise group(s) ", show_some(groups$labels[empty]), " hold no field ",
                 "measurement, so their precision is not identified; merge them with ",
                 "others in `noise_groups`.", class = "input")
  }
  by_group <- function(v) {
    vapply(seq_along(groups$labels), function(k) sum(v[observed & groups$group == k]), 0)
  }
  list(observed = observed, sd = layout$sd, sd_mean = layout$sd_mean, group = groups$group,
       labels = groups$labels, prior = prior, pure_ss = by_group(layout$pure_ss),
       pure_df = as.integer(by_group(layout$n_rep - 1L)), log_sd_excess = layout$log_sd_excess)
}

# The noise group of every library output (library order) from
# `noise_groups`: NULL (one group), "x" (one per x setting), or labels, one
# per output coordinate t or one per library output.
noise_group_index <- function(noise_groups, n_x, n_t) {
  n <- n_x * n_t
  if (is.null(noise_groups)) return(list(group = rep(1L, n), labels = ""))
  if (identical(noise_groups, "x")) {
    return(list(group = rep(seq_len(n_x), each = n_t), labels = paste0("x", seq_len(n_x))))
  }
  if (!is.atomic(noise_groups) || anyNA(noise_groups) ||
      !length(noise_groups) %in% c(n_t, n)) {
    griddy_abort("`noise_groups` must be NULL, \"x\", or labels without NA: one per output ",
                 "coordinate (", n_t, ") or one per library output (", n, "); received ",
                 class(noise_groups)[1], " of length ", length(noise_groups), ".",
                 class = "input")
  }
  v <- as.character(noise_groups)
  if (length(v) == n_t) v <- rep(v, times = n_x)
  labels <- unique(v)
  list(group = match(v, labels), labels = labels)
}

# The thesis's vague Gamma prior on tau (eq. 3.8).
thesis_prior <- function() list(shape = 1e-9, rate = 1e-9)

# The log prior weights of the runs: the user's `run_weights`, or the
# library's own (equal, or a refined library's design correction).
log_run_weights <- function(run_weights, library) {
  n_runs <- lib_n_runs(library)
  if (is.null(run_weights)) {
    return(lib_log_prior(library))
  }
  w <- assert_numeric_vector(run_weights, "run_weights")
  if (length(w) != n_runs) {
    griddy_abort("`run_weights` must have one weight per library run (", n_runs,
                 "); received ", length(w), ".", class = "shape")
  }
  if (any(w < 0) || sum(w) <= 0) {
    griddy_abort("`run_weights` must be >= 0 with a positive sum.")
  }
  # scaled by the largest first: a sum of weights near 1e308 overflows, and
  # every log weight became -Inf (reaching the sampler as an internal error)
  w <- w / max(w)
  log(w / sum(w))
}

# The Gamma(a, b) prior on tau enters the posterior as (b + C/2)^-(a + n/2):
# against b = 0 it multiplies each run's weight by about exp(-n b / C), so it
# is negligible only while n b / C is small for the runs that carry the
# posterior. b is in the units of the squared outputs, so a default that is
# negligible for outputs near 1 can dominate for outputs near 1e-6: then the
# answer depends on the units. A prior the user chose is their statement;
# the default is ours, so warn when it is not negligible (n b / C_min
# above 1%, which moves the posterior by about that much). The smallest
# misfit is taken at the grid point of the best-fitting run's highest log
# likelihood: with a discrepancy, a grid point of a large ratio has tiny
# quadratic forms and a log-determinant that makes it improbable, and its
# smallest C over all grid points warned on data the prior did not touch
# (3 of 15 trials of bench/discrepancy-default.R's logistic system).
prior_influence_threshold <- 0.01

warn_prior_scale <- function(problem) {
  C_min <- apply(as.matrix(problem$C), 2, min)
  best <- collapsed_log_lik(matrix(C_min, 1L), problem$n_obs, problem$setup$logdet,
                            problem$prior) + problem$log_prior_grid
  influence <- problem$n_obs * problem$prior$rate / max(C_min[which.max(best)], 1e-300)
  if (influence > prior_influence_threshold) {
    griddy_warn("The Gamma prior on tau (rate ", format(problem$prior$rate), ") is not ",
                "negligible against the data: n * rate / (smallest misfit) = ",
                format(influence, digits = 3), ", so the posterior depends on the ",
                "outputs' units. Rescale the outputs and field data, or set a rate in ",
                "their units (e.g. `prior = list(shape = 1e-9, rate = 0)`, scale-free).",
                class = "prior")
  }
}
