#' Diagnose the gap between a calibrated simulator and the field data
#'
#' After a calibration, asks three questions of the residual gap: where it
#' lies, which offered effect explains it, and how much adding that effect
#' shrinks it. All three are answered exactly on the library grid (no
#' refits, no sampling).
#'
#' * **where** the data depart from what the fitted noise explains: every
#'   block (one x setting times one window of t) gets an exact
#'   leave-block-out predictive check under the fitted model;
#' * **which** of the offered candidate effects explains the gap, by exact
#'   marginal likelihoods of the base model ("none"), of each candidate, and
#'   of a generic smooth discrepancy ("other");
#' * **how much** each candidate shrinks the gap on data it has not seen:
#'   each x setting is left out in turn and predicted from the others (not
#'   given when the other settings cannot teach the candidate's strength).
#'
#' **Without candidates** (`candidates` missing, `NULL` or an empty list),
#' the question is whether the field data show a gap the simulator cannot
#' absorb at all, and where. `$which` weighs "none" (the base model) against
#' "other", the base model plus the Gaussian-process discrepancy
#' `discrepancy` (a [gp_discrepancy()]; its `prior_none` is its prior
#' probability of no gap within "other"'s grid and its ratio 0 is "none"),
#' by their exact evidence: the fit recomputed with the discrepancy, with
#' the fit's correlation grids, Gamma prior, run weights, noise groups,
#' relative sd and replicates (whose pure error pins the noise, so that it
#' is told from the discrepancy); `$evidence` is its
#' [discrepancy_evidence()]. The answer is "other" when the evidence for it
#' is at least positive: posterior log odds of "other" against "none" above
#' 1 (with equal model priors, a log Bayes factor above 1; Kass and
#' Raftery's inconclusive band is \eqn{\pm 1}); otherwise "none" (with
#' `verdict$reason` `"inconclusive"` when "other" is the more probable of the
#' two), unless the base model fails its own leave-block-out checks (see
#' "Where" below; one noise precision and no replicates only): a gap too
#' local or rough for a
#' smooth discrepancy is "other" too (`verdict$reason` `"blocks"`; the same
#' rule, on the fit's own runs, decides [calibrate()]'s gap warning), and
#' `$where` is then those checks (`settings$where` is `"check"`, else
#' `"discrepancy"`). At matched resolution: the base library is
#' refined as below, then the model with the discrepancy is refined in turn
#' (its posterior over theta may lie elsewhere), predicted runs keeping their
#' prediction error beside the discrepancy, so a truth between coarse runs
#' is not called a gap. Otherwise `$where` has blocks tiling t (the
#' default `windows` tile it as `NULL` with `scan = FALSE` would: at most 8
#' windows per setting, each at least one correlation length), and a block's `score`
#' and `p_value` say where the discrepancy's posterior is away from zero: at
#' a grid point with a discrepancy, the discrepancy given the run is
#' multivariate t; `score` is its block mean's squared distance from zero in
#' the block's posterior metric per dimension, F-distributed about the mean,
#' `p_value` the posterior probability of a discrepancy further from its mean
#' than zero, both averaged over the exact posterior given a discrepancy
#' (\eqn{\lambda > 0}); Benjamini-Hochberg at level `fdr` gives `flagged`,
#' only when the answer is "other". `$map` is the discrepancy's
#' posterior mean (`residual`) and its size in posterior sds (`z`), given a
#' discrepancy. An effect that a shift of theta imitates is spread by the
#' discrepancy over the settings where the shifted simulator misses, not
#' only where the effect acts (Brynjarsdóttir and O'Hagan 2014). `shrinkage`
#' has no rows, `folds` and `separation` are `NULL`.
#'
#' **Matched resolution.** On a coarse library a truth between runs leaves
#' a misfit no run removes, which a candidate with one more dimension, or the
#' smooth discrepancy "other", would explain although there is no effect. So
#' every model is compared where its own posterior is resolved: the base
#' library and each non-zero strength level of each candidate are refined as
#' [refine()] does without a simulator (runs predicted from the library,
#' their prediction error in the likelihood; at most `max_runs` runs each),
#' and a candidate's zero level is the refined base itself. Models that are
#' already resolved are left as they are, and a model that more predicted runs
#' cannot resolve stops after its first round: when that round moved no
#' interval and every parameter still short of effective values has a 95%
#' interval spanning the library's whole range (a strength the data leave
#' flat, as for an effect a shift of theta imitates). Every part of the
#' diagnosis below uses the refined libraries.
#'
#' **Missing data and relative sd.** Field data with missing cells or a
#' relative `sd` (see [field_data()]) are diagnosed on the observed points
#' only, under the fit's noise covariance \eqn{\tau^{-1} S R_g S} restricted
#' to them (dense algebra where the Kronecker shortcuts no longer hold). A
#' block (of "where") or x setting (of "how much") is its observed cells; a
#' block with none is not checked (`n` = 0, `score` and `p_value` `NA`,
#' never flagged) and a setting with none has no fold. Candidates' quadratic
#' forms use the same observed points and sd.
#'
#' **Replicated field data** (several measurements of a cell, see
#' [field_data()]) enter every model as their cell means plus the pure-error
#' sum of squares, as in [calibrate()]: the pure error pins the noise, so that
#' it is told from the gap, and it stays in every leave-out piece (a held-out
#' setting or block leaves out its cell means; the replicates' scatter still
#' informs the noise). Held-out intervals and the map are those of the cell
#' means. As without candidates (and in [calibrate()]'s gap screen), the
#' leave-block-out checks then do not decide: `$where` shows their scores and
#' p-values but flags no block (`settings$where` is `"unflagged"`, else
#' `"check"`), and the evidence alone answers. **Not yet supported with
#' candidates:** noise groups (see [calibrate()]): with a precision per group
#' the block statistic has no single F distribution. Such a fit is an error of
#' class `griddy_error_unsupported` (without candidates they are supported).
#'
#' **Candidates.** Each candidate is a [sim_library()] at the fit's x and t
#' whose `theta` holds the base library's columns plus one or more strength
#' columns; the runs whose strength columns are all 0 must be the base
#' model (they are checked against base runs with the same theta where such
#' runs exist). Its prior is uniform over the distinct strength values
#' (including 0) and, within each, uniform over the runs, so a candidate nests
#' the base model and its Bayes factor pays for its extra dimension through
#' the prior. Best practice is to cross every base theta with every strength.
#'
#' **Models and evidence.** All models share the fit's noise model
#' \eqn{\tau^{-1} R_g} (its correlation grid, its Gamma prior on \eqn{\tau}
#' integrated out) and its prior over base runs. "none" is the fitted
#' library itself; "other" adds a generic smooth discrepancy
#' \eqn{\delta \sim N(0, s \tau^{-1} K_\ell)} to it, with \eqn{K_\ell} a
#' squared-exponential correlation over the scaled (x, t) (length-scale
#' \eqn{\ell} from `other_scales`) and \eqn{s \in \{4, 16, 64, 256\}}
#' the discrepancy's variance relative to the noise (a gap at least twice the
#' noise standard deviation: smaller ones are not "detectable"), both with
#' uniform priors (length-scales too short to correlate neighbouring points
#' are dropped: such a "discrepancy" is white noise, which the base model
#' already has); its evidence is exact too (to rounding: a smooth kernel is
#' factored once at its numerical rank \eqn{r}, then every scale and ratio
#' costs one pass over the runs per correlation grid point, so the cost grows
#' as runs times \eqn{n r}). With
#' relative `sd`, \eqn{s} is relative to the mean noise variance over the
#' observed points (\eqn{\tau^{-1}} times the mean of \eqn{sd^2}), so the
#' discrepancy stays smooth in output units. Model probabilities use `prior_models`
#' (default: equal). **Decision rule:** the answer is the most probable model
#' that is not confounded with theta, if its posterior log odds against
#' "none" exceed 1 (the bar "other" needs without candidates; below it the
#' answer is "none", `verdict$reason` `"inconclusive"`, and
#' `verdict$short` names the model that fell short and its probability);
#' "none" means no detectable gap,
#' "other" a gap that no candidate explains. When that model is "none" but
#' `$where` flags blocks (the base model fails its own check), the answer is
#' "other" too: the gap is real but too local or rough for the smooth
#' discrepancy (`verdict$reason` is then `"blocks"`, else `"evidence"`).
#'
#' **Confounding.** For each non-zero strength, the candidate run nearest
#' the base posterior mode is compared with the base library: the effect's
#' change \eqn{\Delta} (against the zero-strength run with the nearest
#' theta) and the part \eqn{e} of the candidate output that no base run can
#' reproduce (the best base run, refined by a local linear fit on its
#' neighbours in theta), both in the fitted noise metric. The library's own
#' resolution \eqn{e_0} is measured the same way, by imitating base runs near
#' the mode with the other runs. `separable` \eqn{= \sqrt{e^2 - e_0^2} /
#' |\Delta|} is near 0 when a shift of theta imitates the effect; when it is
#' below `confounding_threshold` at some strength whose effect is large enough
#' to judge (\eqn{|\Delta| > 3 e_0}), the candidate is reported as
#' confounded, and the theta column that absorbs it is named, unless the data
#' separate it anyway (Bayes factor against "none" above 100: then the local
#' screen was too pessimistic, or the effect pushes theta out of the
#' library's range). `separable` is
#' `NA` when no strength is large enough to judge.
#'
#' **Where.** For block \eqn{B}, with \eqn{h = R_g^{-1} r} and
#' \eqn{D = h_B' (R_g^{-1})_{BB}^{-1} h_B} (\eqn{R_g} here the noise
#' correlation of the observed points, \eqn{n} their number and \eqn{|B|}
#' the block's observed cells), the statistic
#' \eqn{F = (D/|B|) / ((2b + r'R_g^{-1}r - D)/\nu)}, \eqn{\nu = 2a + n - |B|},
#' is \eqn{F(|B|, \nu)} under the fitted model at fixed (run, correlation);
#' `score` is its mean and `p_value` its tail probability, both averaged over
#' the exact leave-block-out posterior (computed on the runs holding 99.9%
#' of the posterior mass). Benjamini-Hochberg at level `fdr` across blocks
#' gives `flagged`. By default the blocks scan t: windows of every width
#' from one fitted correlation length, doubling, up to the width of a tiling
#' of at most 8 windows, each width at steps of half its length, so a local
#' gap lies inside a window about its own size wherever it sits (a fixed
#' tiling split a peak between two windows). Benjamini-Hochberg over all of
#' them is Simes' test that no block misfits: its level holds under the
#' positive dependence of overlapping windows, so the scan costs about the
#' log of its number of windows in power, not a Bonferroni factor.
#' Overlapping flagged windows of one setting count as one place: only the
#' most significant is `flagged`. A single measurement (one observed output,
#' no replicates) cannot weigh a gap: the verdict is then "none" for reason
#' `"unweighable"`, at no probability, and says it cannot tell.
#'
#' **How much.** For each x setting B, the exact leave-B-out posterior of the
#' base model and of each candidate predicts the held-out outputs from the
#' simulator alone (no residual transfer): `before`/`after` are the pooled
#' RMSEs of the posterior-mean prediction, `lpd_*` the summed exact
#' leave-B-out log predictive densities \eqn{\log p(y_B \mid y_{-B})} and
#' `cover90_*` the fraction of held-out points inside the central 90%
#' predictive interval (simulator plus fitted noise).
#'
#' A fold can learn a candidate's strength only from its training settings.
#' When the effect acts at the held-out setting but not (or too weakly) at
#' the others, as an effect confined to one setting does, every strength
#' fits the training part alike: the strength's posterior there is its prior,
#' and the held-out prediction, so the shrinkage, would be set by the
#' candidate's strength grid, not by the data. So a fold counts as
#' identifying the strength only when its training cells could show the
#' candidate's largest effect (its run near the base posterior mode against
#' the zero-strength run, at each non-zero strength) at the evidence bar a
#' gap needs: log likelihood ratio against no effect,
#' \eqn{\tau d_{-B}' \Sigma_{-B}^{-1} d_{-B} / 2}, above 1 at the fitted noise.
#' A candidate with a fold that does not has its `after`, `shrink`,
#' `lpd_after` and `cover90_after` withheld (`NA`; `identified` `FALSE`,
#' `unidentified` naming the held-out settings), and `print()` and
#' [summary()][summary.gap_diagnosis] say that its shrinkage is not identified
#' by the held-out settings. Its evidence (`$which`) is unaffected: that uses
#' all the data.
#'
#' @param fit A `griddy_fit` from [calibrate()].
#' @param candidates A named list of candidate effects, each a [sim_library()]
#'   as described in Details; `NULL` (the default) or an empty list asks only
#'   whether there is a gap, and where (see "Without candidates").
#' @param windows Blocks over t: `NULL` (default) scans t with overlapping
#'   windows of every width from one fitted correlation length up to that of
#'   a tiling of at most 8 per setting (see "Where"); a single whole number
#'   gives that many equal windows tiling t; a vector of more than one value
#'   gives the window breaks in units of t.
#' @param fdr False discovery rate for flagging blocks. The default, 0.025,
#'   is half the 5% false-alarm budget on data without a gap (the evidence
#'   rule takes the rest); [calibrate()]'s gap screen uses it too.
#' @param prior_models Prior probabilities of the models, a named vector over
#'   `"none"`, the candidate names and `"other"`; `NULL` is equal.
#' @param other_scales Length-scales (on coordinates scaled to \[0, 1]) of the
#'   generic smooth discrepancy "other".
#' @param confounding_threshold Threshold on `separable` below which a
#'   candidate is reported as confounded with theta.
#' @param max_runs The most runs predicted to bring each model to matched
#'   resolution (see Details); 0 compares the libraries as they are.
#' @param seed `NULL`, or a seed for this call only (the predicted runs'
#'   places are random).
#' @param progress Show a progress bar over the steps (refining the base
#'   library and each candidate, the evidence, the checks).
#' @param discrepancy Without candidates, the [gp_discrepancy()] that
#'   "other" adds to the base model (its `ratio` must hold 0).
#' @param control Settings shared by the calibrating functions, from
#'   [griddy_control()]: the defaults of `max_runs` and `progress`; an
#'   argument given in the call overrides its field.
#' @return An object of class `gap_diagnosis`, a list with
#'   * `where`: one row per block: `x` (row of the x setting), `from`, `to`
#'     (t range), `n` (observed points; 0: not checked), `score`, `p_value`,
#'     `flagged`;
#'   * `which`: one row per model, sorted by `prob` decreasing: `effect`,
#'     `prob`, `log_evidence`, `confounded`, `separable`, `detectable` (the
#'     irreducible part of the largest-strength effect in noise standard
#'     deviations), `absorbed_by` (the theta column that imitates it);
#'   * `shrinkage`: one row per candidate: `effect`, `before`, `after`,
#'     `shrink`, `lpd_before`, `lpd_after`, `cover90_before`,
#'     `cover90_after`, `identified` (whether every fold learns the
#'     candidate's strength; if not, the `after` figures and `shrink` are
#'     `NA`, see "How much") and `unidentified` (the x settings whose folds do
#'     not, "" when none);
#'   * `folds`: the same per left-out x setting (`identified` per fold);
#'   * `map`: the pointwise residual field (`x`, `t`, `residual`, `z` =
#'     residual / fitted noise sd, times the point's relative sd where given)
#'     under the base posterior, `NA` at missing cells;
#'   * `separation`: where across x each candidate parts from the theta
#'     column that absorbs it (`NULL` with one x setting): one row per
#'     candidate and x setting: `effect`, `absorbed_by`, `setting` (row of
#'     the x setting), the x columns, `effect_size` (the candidate's effect
#'     there: its output at the strength the confounding screen judged minus
#'     its zero-strength output, near the posterior mode), `unexplained` (the
#'     part of that effect the screen's imitation leaves there, relative to
#'     the larger of the effect and its imitation there: 0 where a shift of
#'     theta imitates it; the imitation is a multiple of the shift to the
#'     imitating base run plus a local linear correction, fitted over all
#'     settings at once) and `ratio` (the setting's own best multiple of that
#'     shift over the multiple fitted to all settings: its drift across x
#'     says where the two part further). Outputs are divided by the cells'
#'     relative sd where given;
#'   * `verdict`: a list with `answer`, `prob`, `reason`, `confounded`,
#'     `advice` (per confounded candidate, the settings where it and the
#'     parameter that absorbs it act most and least alike and where to
#'     measure to separate them, from `separation`; where that says nothing
#'     (one x setting, or alike at every one), a sentence per absorbing
#'     parameter and the generic advice: outside the control settings'
#'     ranges), `n_flagged`, `prob_none` and `short` (NULL, or the model
#'     that fell short of the evidence bar: `effect` and `prob`; and
#'     `mode = "discrepancy"` without candidates);
#'   * `evidence` (without candidates): the [discrepancy_evidence()] of the
#'     fit with the discrepancy, at matched resolution.
#'
#'   `print()` gives the short result: the verdict (answer, probability,
#'   held-out shrinkage, or that it is not identified), the worst flagged block, one line per model and the
#'   design advice (one line per confounded candidate, the generic advice
#'   once); [summary()][summary.gap_diagnosis] explains the
#'   verdict and gives the full tables.
#' @seealso [summary.gap_diagnosis()], [plot.gap_diagnosis()], [posterior_exact()],
#'   [calibrate()]
#' @examples
#' t <- seq(0, 1, length.out = 30)
#' x <- data.frame(load = c(1, 2, 3))
#' sim <- function(a, s) unlist(lapply(x$load, function(l) a * l * sin(3 * t) + s * l^2 * t^2))
#' base <- data.frame(a = seq(0.5, 1.5, length.out = 41))
#' lib <- sim_library(base, t(vapply(base$a, sim, numeric(90), s = 0)), x = x, t = t)
#' grid <- expand.grid(a = base$a, s = c(0, 0.1, 0.2, 0.3))
#' quad <- sim_library(grid, t(mapply(sim, grid$a, grid$s)), x = x, t = t)
#' set.seed(1)
#' field <- field_data(matrix(sim(1, 0.2) + rnorm(90, sd = 0.05), 3, byrow = TRUE), x = x, t = t)
#' fit <- calibrate(lib, field, n_iter = 500, burn_in = 100, seed = 1)
#' gap <- diagnose_gap(fit, list(quadratic = quad))
#' gap
#' gap$which
#' # without candidates: is there a gap at all, and where?
#' diagnose_gap(fit, discrepancy = gp_discrepancy(ratio = c(0, 1, 10, 100)), seed = 1)
#' @export
diagnose_gap <- function(fit, candidates = NULL, windows = NULL, fdr = 0.025,
                         prior_models = NULL, other_scales = c(0.03, 0.1, 0.3),
                         confounding_threshold = 0.05, max_runs = control$max_runs,
                         seed = NULL, progress = control$progress,
                         discrepancy = gp_discrepancy(), control = griddy_control()) {
  control <- assert_control(control)
  if (!inherits(fit, "griddy_fit")) {
    griddy_abort("`fit` must be a griddy_fit from calibrate(); received ", class(fit)[1], ".")
  }
  if (no_candidates(candidates)) {
    # is there a gap at all, and where (gap-discrepancy.R)
    discrepancy <- check_gap_discrepancy(discrepancy)
    return(gap_without_candidates(
      fit, discrepancy, windows, assert_level(fdr, "fdr"), prior_models,
      assert_count(max_runs, "max_runs", min = 0L), assert_seed(seed),
      gap_progress(assert_flag(progress, "progress"), 0L)))
  }
  check_gap_pattern(fit)
  base <- fit$library
  candidates <- check_candidates(candidates, base)
  fdr <- assert_level(fdr, "fdr")
  other_scales <- assert_numeric_vector(other_scales, "other_scales")
  if (any(other_scales <= 0)) griddy_abort("`other_scales` must be positive.")
  confounding_threshold <- assert_level(confounding_threshold, "confounding_threshold")
  models <- c("none", names(candidates), "other")
  log_prior_model <- model_prior(prior_models, models)

  max_runs <- assert_count(max_runs, "max_runs", min = 0L)
  seed <- assert_seed(seed)
  step <- gap_progress(assert_flag(progress, "progress"), length(candidates))
  # every model at matched resolution (gap-resolution.R)
  matched <- with_seed(seed, {
    step("refining the base library")
    base_problem <- matched_base(fit, max_runs)
    list(base = base_problem,
         candidates = lapply(names(candidates), function(nm) {
           step(paste0("refining '", nm, "'"))
           matched_candidate(candidates[[nm]], base_problem, max_runs)
         }))
  })
  names(matched$candidates) <- names(candidates)
  step("the models' evidence")
  ctx <- gap_context(matched$base)
  # the base model's runs x grid table, built once for the whole call
  base_terms <- matched_terms(ctx, lib_outputs(matched$base$library),
                              matched$base$log_prior_run, matched$base$C, matched$base$library,
                              is_plain = is.null(run_errors(matched$base$library)))
  cand_terms <- lapply(matched$candidates, function(m) {
    # the zero level of a refined candidate is the refined base: its rows'
    # leave-out pieces are the base's
    shared <- if (!is.null(m$base_rows)) base_terms
    matched_terms(ctx, m$Y, m$log_prior, m$C, is_plain = m$is_plain, shared = shared)
  })
  other <- other_log_evidence(ctx, base_terms, other_scales)

  log_ev <- c(none = log_sum_exp(base_terms$lj),
              vapply(cand_terms, function(tm) log_sum_exp(tm$lj), numeric(1)),
              other = other)
  post <- log_ev + log_prior_model
  prob <- normalise_log(post)
  # the confounding screen compares a candidate's effect with what a shift of
  # theta imitates, against the base library's own resolution: on the library
  # as it is (a refined base would count its dense predicted runs as
  # imitations of any smooth effect)
  plain <- if (identical(matched$base, fit)) list(ctx = ctx, terms = base_terms) else
    screen_terms(fit)
  white <- screen_white(plain$ctx, plain$terms)
  screen <- lapply(names(candidates), function(nm) {
    sc <- confounding_screen(plain$ctx, plain$terms, candidates[[nm]], names(lib_theta(base)),
                             confounding_threshold, nm, white)
    # the data themselves separate it: the screen's local view was too pessimistic
    if (log_ev[[nm]] - log_ev[["none"]] > log(100)) sc$confounded <- FALSE
    sc
  })
  names(screen) <- names(candidates)
  which_tab <- data.frame(
    effect = models, prob = unname(prob), log_evidence = unname(log_ev),
    confounded = c(FALSE, vapply(screen, `[[`, logical(1), "confounded"), FALSE),
    separable = c(NA, vapply(screen, `[[`, numeric(1), "separable"), NA),
    detectable = c(NA, vapply(screen, `[[`, numeric(1), "detectable"), NA),
    absorbed_by = c(NA, vapply(screen, `[[`, character(1), "absorbed_by"), NA),
    stringsAsFactors = FALSE)
  which_tab <- which_tab[order(which_tab$prob, decreasing = TRUE), ]
  rownames(which_tab) <- NULL

  step("where and how much")
  where <- gap_where(ctx, base_terms, windows, fdr)
  # the one rule of the block checks (block_check_applies(), as without
  # candidates and in calibrate()'s screen): with replicates or noise groups
  # they are shown, not flagged, and the evidence alone answers
  checks <- block_check_applies(fit)
  if (!checks) where$blocks$flagged <- FALSE
  folds <- gap_folds(ctx, base_terms, cand_terms, lapply(screen, `[[`, "identified"))
  shrink <- summarise_folds(folds, names(candidates), gap_x_labels(list(x = lib_x(base))))
  separation <- do.call(rbind, unname(lapply(screen, `[[`, "separation")))
  verdict <- gap_verdict(which_tab, separation, base, where)
  structure(list(where = where$blocks, which = which_tab, shrinkage = shrink,
                 folds = folds, map = where$map, separation = separation, verdict = verdict,
                 settings = list(fdr = fdr, windows = where$breaks,
                                 where = if (checks) "check" else "unflagged",
                                 other_scales = other_scales,
                                 confounding_threshold = confounding_threshold),
                 x = lib_x(base), t = lib_t(base)),
            class = "gap_diagnosis")
}

# A function(status) that advances diagnose_gap()'s progress bar one step
# (the refinement of the base and of each candidate, the evidence, the
# checks); the bar closes when the caller returns. Does nothing without
# `progress`.
gap_progress <- function(progress, n_candidates, envir = parent.frame()) {
  if (!progress) return(function(status) invisible())
  bar <- cli::cli_progress_bar(
    "Diagnosing the gap", total = n_candidates + 3L, .envir = envir,
    format = "{cli::pb_name} {cli::pb_bar} {cli::pb_current}/{cli::pb_total} {cli::pb_status}")
  first <- TRUE
  function(status) {
    cli::cli_progress_update(inc = if (first) 0 else 1, status = status, id = bar,
                             force = TRUE, .envir = envir)
    first <<- FALSE
  }
}

# ---- candidates --------------------------------------------------------------

# The leave-out algebra works on the observed points with one tau (missing
# cells and relative sd are fine). Noise groups are not supported: each group's
# own tau makes the leave-block-out predictive a product of Student-t pieces
# with different degrees of freedom, which the block statistic F does not have,
# and "other"'s discrepancy would need a scale per group.
check_gap_pattern <- function(fit) {
  n_groups <- length(fit$setup$group_sizes)
  if (n_groups > 1L) {
    griddy_abort("diagnose_gap() does not yet support fits with noise groups (this fit has ",
                 n_groups, ") with candidates; missing field data and relative `sd` are supported. ",
                 "Refit without `noise_groups` (one tau) to weigh candidates, or diagnose ",
                 "without candidates (is there a gap, and where).",
                 class = "unsupported")
  }
  # replicates are fine: they enter the likelihood as their cell means plus a
  # pure-error sum of squares, which every leave-out piece keeps (it informs
  # tau whatever setting or block is left out)
}

# More measurements than measured cells: replicates.
has_replicates <- function(fit) fit$n_obs > sum(!is.na(fit$y_field))

check_candidates <- function(candidates, base) {
  if (inherits(candidates, "sim_library") || !is.list(candidates) || length(candidates) == 0L) {
    griddy_abort("`candidates` must be a named list of sim_library objects (one per ",
                 "effect); received ", class(candidates)[1], ".")
  }
  nm <- names(candidates)
  if (is.null(nm) || any(nm == "") || anyDuplicated(nm)) {
    griddy_abort("`candidates` must have distinct, non-empty names.")
  }
  if (any(nm %in% c("none", "other"))) {
    griddy_abort("`candidates` names must not be \"none\" or \"other\" (reserved answers).")
  }
  base_cols <- names(lib_theta(base))
  for (k in nm) {
    cand <- candidates[[k]]
    what <- paste0("Candidate `", k, "`")
    if (!inherits(cand, "sim_library")) {
      griddy_abort(what, " must be a sim_library; received ", class(cand)[1], ".")
    }
    if (lib_n_x(cand) != lib_n_x(base) ||
        (!is.null(lib_x(base)) && (!identical(names(lib_x(cand)), names(lib_x(base))) ||
                              !all(same_values(as.matrix(lib_x(cand)), as.matrix(lib_x(base))))))) {
      griddy_abort(what, " must have the fit's x settings (", lib_n_x(base), " row(s) of ",
                   show_some(names(lib_x(base))), ", in the same order); it has ", lib_n_x(cand),
                   " row(s) of ", show_some(names(lib_x(cand))), ".")
    }
    if (length(lib_t(cand)) != length(lib_t(base)) || !all(same_values(lib_t(cand), lib_t(base)))) {
      griddy_abort(what, " must have the fit's t (", length(lib_t(base)), " value(s) from ",
                   format(min(lib_t(base))), " to ", format(max(lib_t(base))), "); it has ",
                   length(lib_t(cand)), " from ", format(min(lib_t(cand))), " to ",
                   format(max(lib_t(cand))), ".")
    }
    missing_cols <- setdiff(base_cols, names(lib_theta(cand)))
    if (length(missing_cols) > 0L) {
      griddy_abort(what, " lacks the base theta column(s) ", show_some(missing_cols), ".")
    }
    strength <- setdiff(names(lib_theta(cand)), base_cols)
    if (length(strength) == 0L) {
      griddy_abort(what, " has no strength column: its theta must hold the base columns (",
                   show_some(base_cols), ") plus at least one column for the effect's ",
                   "strength, 0 meaning off.")
    }
    zero <- rowSums(abs(as.matrix(lib_theta(cand)[strength]))) == 0
    if (!any(zero)) {
      griddy_abort(what, " has no zero-strength runs (", show_some(strength),
                   " all 0): it must nest the base model.")
    }
    if (all(zero)) {
      griddy_abort(what, " has only zero-strength runs: its strength column(s) ",
                   show_some(strength), " must take non-zero values too.")
    }
    check_zero_strength(cand, base, zero, what)
  }
  candidates
}

# Zero-strength runs that share a base run's theta must reproduce its outputs.
check_zero_strength <- function(cand, base, zero, what) {
  cols <- names(lib_theta(base))
  hit <- match_rows(lib_theta(cand)[zero, cols, drop = FALSE], lib_theta(base)[cols])
  ok <- !is.na(hit)
  if (!any(ok)) return(invisible())
  yc <- lib_outputs(cand, which(zero)[ok])
  yb <- lib_outputs(base, hit[ok])
  scale <- max(abs(yb), 1e-300)
  worst <- max(abs(yc - yb)) / scale
  if (worst > 1e-6) {
    griddy_abort(what, "'s zero-strength runs do not reproduce the base library: at the ",
                 "same theta the outputs differ by up to ", format(worst, digits = 3),
                 " (relative). Strength 0 must switch the effect off.")
  }
}

# Prior over a candidate's runs before refinement: uniform over the distinct
# strength values, uniform over the runs within each (matched_candidate()
# keeps the first part and refines the second).
candidate_log_prior <- function(cand, base_cols) {
  strength <- as.matrix(lib_theta(cand)[setdiff(names(lib_theta(cand)), base_cols)])
  level <- strength_levels(strength)
  count <- tabulate(level)
  -log(max(level)) - log(count[level])
}

# The level of each run: its distinct strength values (equal as
# match_rows() has it), numbered in order of first appearance.
strength_levels <- function(strength) row_groups(strength)

model_prior <- function(prior_models, models) {
  if (is.null(prior_models)) return(stats::setNames(rep(-log(length(models)), length(models)),
                                                    models))
  p <- assert_numeric_vector(prior_models, "prior_models")
  if (is.null(names(prior_models)) || !setequal(names(prior_models), models)) {
    griddy_abort("`prior_models` must be named by the models ", show_some(models, 10), ".")
  }
  if (any(p < 0) || sum(p) <= 0) griddy_abort("`prior_models` must be >= 0 with a positive sum.")
  p <- p[match(models, names(prior_models))]
  stats::setNames(log(p / sum(p)), models)
}
