# diagnose_gap() without candidates: is there a gap at all, and where? The
# answer weighs the base model ("none") against the base model plus a
# generic Gaussian-process discrepancy ("other", a gp_discrepancy()) by the
# exact evidence of the fit recomputed with the discrepancy, at matched
# resolution: the base library is first refined as diagnose_gap() refines it
# for candidates (runs predicted from the library, their prediction error in
# the likelihood), so that a truth between coarse runs is not called a gap.
# "Where" is where the discrepancy's posterior is away from zero. See
# ?diagnose_gap, "Without candidates".

# The diagnosis without candidates, in diagnose_gap()'s return shape.
gap_without_candidates <- function(fit, discrepancy, windows, fdr, prior_models, max_runs,
                                   seed, step) {
  base <- fit$library
  log_prior_model <- model_prior(prior_models, c("none", "other"))
  step("refining the base library")
  matched <- with_seed(seed, matched_base(no_discrepancy_problem(fit), max_runs))
  step("the evidence for a discrepancy")
  # then the model with the discrepancy, whose posterior over theta may lie
  # elsewhere (the discrepancy absorbing what theta imitated), refined in turn
  problem <- discrepancy_problem(matched, discrepancy)
  post <- NULL
  if (max_runs > 0L) {
    refined <- with_seed(seed, refine_rounds(
      problem, NULL, max_runs, default_runs_per_round(lib_theta(problem$library))))
    problem <- refined$problem
    # the last round's posterior is the refined problem's
    post <- refined$posterior
  }
  exact <- exact_from_problem(problem, joint = TRUE, post = post)
  evidence <- discrepancy_evidence(exact)
  # each model's evidence: its grid points' mass over its prior mass
  log_mass <- attr(exact, "log_grid_mass")
  none <- problem$setup$discrepancy$ratio[problem$setup$gd] == 0
  prior_none <- evidence$prior_none
  log_ev <- c(none = log_sum_exp(log_mass[none]) - log(prior_none),
              other = log_sum_exp(log_mass[!none]) - log1p(-prior_none))
  prob <- normalise_log(log_ev + log_prior_model)
  which_tab <- data.frame(effect = c("none", "other"), prob = unname(prob),
                          log_evidence = unname(log_ev), confounded = FALSE,
                          separable = NA_real_, detectable = NA_real_,
                          absorbed_by = NA_character_, stringsAsFactors = FALSE)
  which_tab <- which_tab[order(which_tab$prob, decreasing = TRUE), ]
  rownames(which_tab) <- NULL
  found <- gap_found(prob) && gap_weighable(fit$n_obs)
  step("where the discrepancy lies")
  # the base model's own leave-block-out checks (gap-where.R): a
  # gap too local or rough for a smooth discrepancy (gap_shown())
  check <- if (block_check_applies(fit)) base_check(matched, windows, fdr)
  # where the discrepancy lies, over the tiling of t (the check's scan, by
  # default, holds overlapping windows of every width: many, and its flags
  # are what a gap the discrepancy misses is told by)
  where <- discrepancy_where(problem, exact, windows, fdr, found)
  if (!found && !is.null(check) && any(check$blocks$flagged)) {
    where <- c(check, list(kind = "check"))
  }
  verdict <- discrepancy_verdict(which_tab, base, where, prob, found, gap_weighable(fit$n_obs))
  structure(list(where = where$blocks, which = which_tab, shrinkage = empty_shrinkage(),
                 folds = NULL, map = where$map, separation = NULL, verdict = verdict,
                 evidence = evidence,
                 settings = list(fdr = fdr, windows = where$breaks, discrepancy = discrepancy,
                                 runs = lib_n_runs(problem$library), where = where$kind),
                 x = lib_x(base), t = lib_t(base)),
            class = "gap_diagnosis")
}

# gap_where() of a base problem (diagnose_gap()'s refined one, or a fit in
# the gap screen): its leave-block-out checks, over its runs `runs` (all by
# default; the screen passes those that carry the posterior, as gap_where()
# reads no others).
base_check <- function(matched, windows, fdr, runs = NULL) {
  ctx <- gap_context(matched)
  if (is.null(runs)) runs <- seq_len(lib_n_runs(matched$library))
  # a library without predicted runs has C the plain forms: not recomputed
  terms <- matched_terms(ctx, lib_outputs(matched$library, runs), matched$log_prior_run[runs],
                         matched$C[runs, , drop = FALSE], matched$library,
                         is_plain = is.null(run_errors(matched$library)))
  terms$rows <- runs
  gap_where(ctx, terms, windows, fdr)
}

# Whether the base model's block checks answer for a fit: one noise
# precision and no replicates (with them the checks of predicted runs flag
# blocks in data without a gap, so the evidence alone answers), and more
# than one measurement (gap_weighable(): a single one leaves nothing to
# predict it from).
block_check_applies <- function(fit) {
  length(fit$setup$group_sizes) == 1L && !has_replicates(fit) && gap_weighable(fit$n_obs)
}

empty_shrinkage <- function() {
  data.frame(effect = character(0), before = numeric(0), after = numeric(0),
             shrink = numeric(0), lpd_before = numeric(0), lpd_after = numeric(0),
             cover90_before = numeric(0), cover90_after = numeric(0))
}

# ---- the problems -----------------------------------------------------------------

# The fit's problem without a discrepancy (the fit itself when it has none).
no_discrepancy_problem <- function(fit) {
  if (is.null(fit$setup$discrepancy)) return(fit)
  discrepancy_problem(fit, NULL)
}

# A problem (or fit) recomputed with `discrepancy` (NULL: none): the same
# library and runs' prior weights, field data, rho grids, Gamma prior, noise
# groups, relative sd and replicates' pure error; its setup rebuilt with the
# discrepancy's grid points and C recomputed (a predicted run's C keeps its
# prediction error, now beside the discrepancy).
discrepancy_problem <- function(problem, discrepancy) {
  setup <- problem$setup
  library <- problem$library
  pattern <- setup_noise_pattern(setup, lib_n_x(library) * lib_n_t(library), problem$prior)
  rho_x <- unname(setup$rho_x)
  if (!is.null(discrepancy)) {
    discrepancy <- discrepancy_for_data(discrepancy, library, problem$y_field, pattern)
  }
  new <- correlation_setup(library, rho_x, setup$rho_t, setup$x_power, pattern, discrepancy)
  # the replicates' constant of the log-determinant (the same at every grid
  # point, field_layout()) is not kept in a setup: take it from the old one,
  # whose first grid point has the same R_g and no discrepancy
  new$logdet <- new$logdet + (setup$logdet[1] - new$logdet[1])
  C <- misfit_table(library, problem$y_field, new, problem$prior)
  new_griddy_problem(library, problem$y_field, problem$prior, problem$log_prior_run, new, C)
}

# noise_pattern() of a setup, rebuilt from what the setup keeps (every point
# observed, one group and no sd for a Kronecker setup).
setup_noise_pattern <- function(setup, n, prior) {
  kept <- setup$pattern
  if (is.null(kept)) {
    return(list(observed = rep(TRUE, n), sd = NULL, sd_mean = NULL, group = rep(1L, n),
                labels = "", prior = prior, pure_ss = 0, pure_df = 0L, log_sd_excess = 0))
  }
  layout <- noise_layout(setup)
  sd_mean <- NULL
  if (!is.null(layout$scale)) {
    sd_mean <- rep(NA_real_, n)
    sd_mean[layout$obs] <- 1 / layout$scale
  }
  c(kept[c("observed", "sd")], list(sd_mean = sd_mean), kept[c("group", "labels")],
    list(prior = setup$fold_prior, pure_ss = setup$pure_ss,
         pure_df = as.integer(setup$group_sizes - lengths(layout$groups)),
         log_sd_excess = 0))
}

# ---- where ---------------------------------------------------------------------

# Where the discrepancy's posterior is away from zero, block by block (one x
# setting times one window of t, as for the candidates' leave-block-out
# checks). At a grid point with ratio lambda > 0, given run i, delta at the
# observed outputs has delta_law()'s mean m and covariance tau^-1 P; once
# tau is integrated out (per noise group, with the group's C and size) it is
# a multivariate t with 2a + n degrees of freedom and scale matrix v P,
# v = (b + C/2) / (a + n/2). A block's statistic is T = m_B' P_B^+ m_B /
# (v d) (d the rank of P_B, taken over the sd-scaled outputs), F(d, 2a + n)
# distributed about the mean, and p = P(F > T) is the posterior probability
# of discrepancies further from the mean than zero. `score` and `p_value`
# average T and p over the exact posterior given a discrepancy (the pairs of
# run and grid point holding 99.9% of the mass with lambda > 0); blocks are
# flagged (Benjamini-Hochberg at `fdr`) only when the evidence finds a gap
# (`found`): $where says where the gap lies once the evidence says there is
# one.
discrepancy_where <- function(problem, exact, windows, fdr, found) {
  setup <- problem$setup
  library <- problem$library
  n_x <- lib_n_x(library)
  n_t <- lib_n_t(library)
  t <- lib_t(library)
  layout <- noise_layout(setup)
  obs <- layout$obs
  none <- setup$discrepancy$ratio[setup$gd] == 0
  joint <- exact$joint
  # the joint without a discrepancy, and with one: copies with the other
  # columns zeroed (gap_windows() reads only where its largest entry is,
  # which the log would not move)
  w_none <- joint
  w_none[, !none] <- 0
  win <- if (is.list(windows)) windows else gap_windows(list(n_t = n_t, t = t,
                          points = lapply(seq_len(n_grid_points(setup)), function(g) {
                            list(phi = setup$phi[, setup$gt[g]])
                          })),
                     list(lj = w_none), windows, scan = FALSE)
  rm(w_none)
  blocks <- expand.grid(w = seq_along(win), x = seq_len(n_x))
  pos <- lapply(seq_len(nrow(blocks)), function(b) {
    block_positions(obs, blocks$x[b], win[[blocks$w[b]]], n_t)
  })
  size <- lengths(pos)
  w_other <- joint
  w_other[, none] <- 0
  pairs <- if (sum(w_other) > 0) top_pairs(w_other, 0.999, 200L) else integer(0)
  stat <- matrix(0, length(pairs), nrow(blocks))
  pval <- matrix(1, length(pairs), nrow(blocks))
  delta <- matrix(0, length(pairs), length(obs))
  delta_var <- delta
  wp <- if (length(pairs) > 0L) w_other[pairs] / sum(w_other[pairs]) else numeric(0)
  pairs <- arrayInd(pairs, dim(joint))
  a <- problem$prior$shape
  b <- problem$prior$rate
  Y <- if (nrow(pairs) > 0L) lib_outputs(library, unique(pairs[, 1]))
  row_of <- match(pairs[, 1], unique(pairs[, 1]))
  kernels <- if (nrow(pairs) > 0L) {
    discrepancy_kernels(library, attr(setup$discrepancy, "kernels"))
  }
  scale <- if (is.null(layout$scale)) rep(1, length(obs)) else layout$scale
  for (g in unique(pairs[, 2])) {
    law <- delta_law(setup, g, kernels, observed_only = TRUE)
    P <- scaled_delta_covs(law, layout)
    at <- which(pairs[, 2] == g)
    Yg <- Y[row_of[at], , drop = FALSE]
    Ck <- group_quad_forms(Yg, problem$y_field, setup, g)
    resid <- matrix(problem$y_field, length(at), ncol(Y), byrow = TRUE) - Yg
    delta[at, ] <- delta_means(law, resid)[, obs, drop = FALSE]
    M <- sweep(delta[at, , drop = FALSE], 2, scale, "*")   # the mean, sd-scaled
    scale2 <- matrix(0, length(at), length(layout$groups))
    for (k in seq_along(layout$groups)) {
      scale2[, k] <- (b + Ck[, k] / 2) / (a + setup$group_sizes[k] / 2)
      delta_var[at, layout$groups[[k]]] <- outer(scale2[, k], delta_cov_diag(law$groups[[k]]))
    }
    for (bl in which(size > 0L)) {
      parts <- block_group_parts(pos[[bl]], layout$groups, P)
      for (j in seq_along(at)) {
        tt <- 0
        d <- 0
        for (part in parts) {
          m <- M[j, part$pos]
          z <- crossprod(part$vectors, m)
          tt <- tt + sum(z^2 / part$values) / scale2[j, part$group]
          d <- d + length(part$values)
        }
        if (d == 0L) next
        nu <- 2 * a + sum(setup$group_sizes[unique(vapply(parts, `[[`, 1L, "group"))])
        stat[at[j], bl] <- tt / d
        # several noise groups in a block: their scales differ, so the sum is
        # taken as chi-square (large degrees of freedom) rather than F
        pval[at[j], bl] <- if (length(parts) == 1L) {
          stats::pf(tt / d, d, nu, lower.tail = FALSE)
        } else {
          stats::pchisq(tt, d, lower.tail = FALSE)
        }
      }
    }
  }
  score <- colSums(wp * stat)
  p_value <- colSums(wp * pval)
  score[size == 0L] <- NA_real_
  p_value[size == 0L] <- NA_real_
  # where the gap lies, once the evidence says there is one
  flagged <- stats::p.adjust(p_value, "BH") <= fdr & found
  t_of <- function(f) vapply(blocks$w, function(k) f(t[win[[k]]]), numeric(1))
  out <- data.frame(x = blocks$x, from = t_of(min), to = t_of(max), n = size,
                    score = score, p_value = p_value, flagged = flagged & !is.na(flagged))
  list(blocks = out, breaks = win, kind = "discrepancy",
       map = discrepancy_map(delta, delta_var, wp, obs, n_x, n_t, t))
}

# Per noise group of an observed-only delta_law(): delta's covariance P per
# unit tau^-1 over the group's observed outputs, in sd-scaled units (S^-1 P
# S^-1), where the blocks' numerical ranks are judged.
scaled_delta_covs <- function(law, layout) {
  lapply(seq_along(law$groups), function(k) {
    grp <- law$groups[[k]]
    if (!is.null(grp$L)) {
      # low-rank factors: P = L diag(p) L', its blocks formed where needed
      s <- if (is.null(layout$scale)) 1 else layout$scale[layout$groups[[k]]]
      return(list(L = sweep(grp$L * s, 2, sqrt(grp$p), "*")))
    }
    P <- delta_cov(grp)
    if (is.null(layout$scale)) return(P)
    s <- layout$scale[layout$groups[[k]]]
    P * outer(s, s)
  })
}

# A block's parts, one per noise group it touches: the block's positions in
# that group's data vector (`pos`, over all observed points), and the
# eigen-pieces of its block of P (scaled_delta_covs(), one per group) above
# its numerical rank.
block_group_parts <- function(pos, groups, P) {
  parts <- list()
  for (k in seq_along(groups)) {
    here <- pos[pos %in% groups[[k]]]
    if (length(here) == 0L) next
    j <- match(here, groups[[k]])
    block <- if (is.list(P[[k]])) {
      tcrossprod(P[[k]]$L[j, , drop = FALSE])
    } else {
      P[[k]][j, j, drop = FALSE]
    }
    e <- eigen(block, symmetric = TRUE)
    keep <- e$values > max(e$values, 0) * 1e-8 & e$values > 0
    parts[[length(parts) + 1L]] <- list(group = k, pos = here, values = e$values[keep],
                                        vectors = e$vectors[, keep, drop = FALSE])
  }
  parts
}

# The discrepancy's posterior mean over (x, t), given a discrepancy (lambda >
# 0), and its size in posterior sds (`z`); NA at missing cells. `residual`
# is that mean (what the model misses beyond the noise) so that plot() maps it.
discrepancy_map <- function(delta, delta_var, wp, obs, n_x, n_t, t) {
  mean_obs <- colSums(delta * wp)
  var_obs <- colSums((delta_var + delta^2) * wp) - mean_obs^2
  res <- rep(NA_real_, n_x * n_t)
  z <- res
  res[obs] <- mean_obs
  z[obs] <- mean_obs / sqrt(pmax(var_obs, 1e-300))
  if (length(wp) == 0L) z[obs] <- 0
  data.frame(x = rep(seq_len(n_x), each = n_t), t = rep(t, n_x), residual = res, z = z)
}

# ---- arguments -------------------------------------------------------------------

# No candidates: `candidates` missing, NULL or an empty list.
no_candidates <- function(candidates) {
  is.null(candidates) || (is.list(candidates) && !inherits(candidates, "sim_library") &&
                            length(candidates) == 0L)
}

# The discrepancy "other" stands for: a gp_discrepancy() whose ratio grid holds
# 0 (the base model) and positive values.
check_gap_discrepancy <- function(discrepancy) {
  discrepancy <- assert_discrepancy(discrepancy)
  if (is.null(discrepancy) || !any(discrepancy$ratio == 0) || !any(discrepancy$ratio > 0)) {
    griddy_abort("`discrepancy` must be a gp_discrepancy() whose `ratio` holds 0 (no gap) and ",
                 "positive values.", class = "input")
  }
  discrepancy
}
