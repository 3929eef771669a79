# Matched resolution for diagnose_gap(). On a coarse library a truth between
# runs leaves a misfit that no run removes; compared with that, a candidate
# with one more dimension, or the smooth discrepancy "other", explains the
# misfit and wins although there is no effect at all. So every model is
# compared at a resolution where its own posterior is resolved: the base
# library is refined by refine_rounds() without a simulator (runs predicted
# from the library, their prediction error in the likelihood), and so are a
# candidate's non-zero strength levels, over theta and strength; its zero
# level is the refined base itself, so a candidate still nests the base
# model exactly. A model that is already resolved is left as it is.

# The refined base problem.
matched_base <- function(fit, max_runs) {
  if (max_runs == 0L) return(fit)
  refine_rounds(fit, NULL, max_runs, default_runs_per_round(lib_theta(fit$library)),
                settled = settled_in_range)$problem
}

# Whether more predicted runs cannot resolve a model further: after a round
# that moved no interval bound by more than `interval_tol` of its width and
# cut off no side, every parameter still limited (too few effective values,
# see resolution_table()) has a 95% interval that already spans the
# library's whole range in it (to the edge band of resolution_table()). The
# data do not narrow such a parameter inside the range, and runs predicted in
# it (the box stays inside the range) only add values to a flat marginal: on
# a candidate whose strength a shift of theta imitates, refine_rounds() would
# otherwise spend all of `max_runs` on it. The evidence such runs would still
# change is an average over a marginal the data leave flat.
settled_in_range <- function(state, previous) {
  tab <- state$table
  width <- pmax(tab$upper - tab$lower, previous$upper - previous$lower)
  moved <- pmax(abs(tab$lower - previous$lower), abs(tab$upper - previous$upper))
  if (!all(moved <= interval_tol * width) || any(truncated_sides(state))) return(FALSE)
  range0 <- library_box(lib_base(state$problem$library))
  band <- edge_band_share * (range0[2, ] - range0[1, ])
  spans <- tab$lower <= range0[1, ] + band & tab$upper >= range0[2, ] - band
  open <- tab$limited & !tab$constant
  all(spans[open])
}

# A candidate at matched resolution: its runs' theta (base columns plus
# strength), outputs Y, quadratic forms C and log prior weights; when refined
# (`base_rows` given), its first `base_rows` runs are the refined base and Y
# holds the outputs of the rows after them only. Its prior
# keeps the weight 1/S of each of its S strength levels: the zero level is
# the refined base (so the candidate nests the base model exactly), and the
# non-zero levels, together, are refined over theta and strength at once,
# so that an effect whose strength lies between the levels is resolved too
# (the prior over the non-zero part becomes uniform over the box of theta and
# the non-zero strengths).
matched_candidate <- function(cand, base_problem, max_runs) {
  base_cols <- names(lib_theta(base_problem$library))
  strength_cols <- setdiff(names(lib_theta(cand)), base_cols)
  strength <- as.matrix(lib_theta(cand)[strength_cols])
  n_levels <- max(strength_levels(strength))
  if (max_runs == 0L) {
    Y <- lib_outputs(cand)
    return(list(theta = lib_theta(cand), Y = Y,
                C = plain_quad_forms(Y, base_problem$y_field, base_problem$setup),
                log_prior = candidate_log_prior(cand, base_cols), is_plain = TRUE))
  }
  zero <- problem_part(base_problem)
  zero$log_prior <- zero$log_prior - log(n_levels)
  on <- nonzero_part(cand, which(rowSums(abs(strength)) > 0), base_problem, max_runs)
  on$log_prior <- on$log_prior + log((n_levels - 1) / n_levels)
  # theta stacked column by column, the zero level's strength 0 (rbind() or
  # cbind() of long data frames costs more)
  n_zero <- nrow(zero$theta)
  theta <- as.data.frame(lapply(stats::setNames(nm = c(base_cols, strength_cols)), function(nm) {
    c(if (nm %in% strength_cols) numeric(n_zero) else zero$theta[[nm]], on$theta[[nm]])
  }), check.names = FALSE)
  # Y: the outputs of the rows after the zero level's (whose are the base's)
  list(theta = theta, Y = on$Y, C = rbind(zero$C, on$C),
       log_prior = c(zero$log_prior, on$log_prior), is_plain = FALSE,
       base_rows = nrow(zero$Y))
}

problem_part <- function(problem) {
  list(theta = lib_theta(problem$library), Y = lib_outputs(problem$library), C = problem$C,
       log_prior = problem$log_prior_run)
}

# The non-zero strength runs of a candidate as one library over theta and
# strength, refined like the base. Too few runs to emulate are left as they
# are.
nonzero_part <- function(cand, rows, base_problem, max_runs) {
  theta <- lib_theta(cand)[rows, , drop = FALSE]
  Y <- lib_outputs(cand, rows)
  if (length(rows) < 2L * ncol(theta) + 2L) {
    C <- plain_quad_forms(Y, base_problem$y_field, base_problem$setup)
    return(list(theta = theta, Y = Y, C = C, log_prior = rep(-log(length(rows)), length(rows))))
  }
  # rows of a checked library: distinct, finite runs (sim_library() would
  # check its 10^5 rows again)
  part <- runs_piece(theta, Y, lib_x(cand), lib_t(cand))
  problem <- new_griddy_problem(part, base_problem$y_field, base_problem$prior,
                                lib_log_prior(part), base_problem$setup)
  problem_part(refine_rounds(problem, NULL, max_runs, default_runs_per_round(lib_theta(part)),
                             settled = settled_in_range)$problem)
}

# gap_terms() of a model at matched resolution: its table C is the plain
# quadratic forms of Y unless some runs were predicted (their C holds the
# prediction error), which the leave-out algebra then computes apart.
matched_terms <- function(ctx, Y, log_prior, C, library = NULL, is_plain = FALSE,
                          shared = NULL) {
  # a table known to be the plain forms (no predicted run) is not recomputed
  if (is_plain) return(gap_terms(ctx, Y, log_prior, Q = C, shared = shared))
  # the shared rows' plain forms are the other model's Q (Y holds the rest)
  plain <- rbind(shared$Q, plain_quad_forms(Y, ctx$y, ctx$setup))
  if (same_table(plain, C)) {
    return(gap_terms(ctx, Y, log_prior, Q = C, shared = shared))
  }
  terms <- gap_terms(ctx, Y, log_prior, Q = plain, C = C, shared = shared)
  terms$emulation <- run_errors(library)
  terms
}

# Whether two misfit tables agree to 1e-12 in mean relative difference (as
# all.equal(), without its passes for names, attributes and missing values:
# the tables are finite).
same_table <- function(a, b) {
  sum(abs(a - b)) <= 1e-12 * sum(abs(a))
}

# The fit's own context and base terms, for the confounding screen (which
# reads the outputs, Q and the log joint, not the leave-out pieces).
screen_terms <- function(fit) {
  ctx <- gap_context(fit)
  lj <- collapsed_log_joint(fit$C, ctx$n, ctx$logdet, ctx$prior, fit$log_prior_run,
                            ctx$log_prior_grid)
  list(ctx = ctx, terms = list(Y = lib_outputs(fit$library), Q = fit$C, lj = lj))
}
