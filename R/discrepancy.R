# A model discrepancy delta(x, t) in the likelihood: its specification, its
# prior over a grid of hyperparameters and its kernel. How it enters the
# quadratic forms is in engine.R (dense_factors()).
#
# Model: y = g_i + delta + e, delta ~ N(0, tau^-1 lambda K_l), e ~ N(0,
# tau^-1 S R_g S), so Cov(y | i, g, lambda, l, tau) = tau^-1 (S R_g S +
# lambda K_l): lambda is the discrepancy's variance relative to the noise's
# and l its length scales. tau integrates out as before, so (lambda, l) are
# extra axes of the correlation grid and the posterior over runs x grid
# points stays exact (see ../shared/notes/discrepancy.md, section 3). The
# point lambda = 0 is the model without a discrepancy, so the Bayes factor
# for "a gap" is read off the grid posterior (discrepancy_evidence()).

#' A Gaussian-process model discrepancy
#'
#' Specifies a discrepancy \eqn{\delta(x, t)} between the simulator and
#' reality for [calibrate()] and [posterior_exact()]: the field data are
#' modelled as \eqn{y = g(x, t, \theta) + \delta(x, t) + \epsilon} with
#' \eqn{\delta} a zero-mean Gaussian process independent of the noise. Its
#' covariance is \eqn{\tau^{-1} \lambda K_\ell} with
#' \deqn{K_\ell[(x, t), (x', t')] = \exp(-\|x - x'\|^2 / \ell_x^2)
#'   \exp(-(t - t')^2 / \ell_t^2)}
#' over the control settings and the output coordinate, each scaled to
#' \[0, 1] per column as for the correlation grid (see [rho_grid()]), so
#' that the data's covariance is \eqn{\tau^{-1}(S R_g S + \lambda K_\ell)}.
#' The ratio \eqn{\lambda} is the discrepancy's variance over the noise's:
#' it has no units, so one default grid serves data of any scale.
#'
#' \eqn{\lambda}, \eqn{\ell_x} and \eqn{\ell_t} take the values of grids and
#' are integrated out exactly, as the correlation \eqn{\rho} is: every
#' combination is one more point of the correlation grid, and \eqn{\tau} is
#' integrated out as before. \eqn{\lambda = 0} is the model without a
#' discrepancy; it has prior probability `prior_none`, and the other points
#' share the rest equally. So the posterior probability of \eqn{\lambda = 0}
#' gives the Bayes factor for a discrepancy, which `print()` and `summary()`
#' of the fit report.
#'
#' **Orthogonal to theta** (the default). A discrepancy that can imitate a
#' change of \eqn{\theta} competes with \eqn{\theta} for the same misfit:
#' \eqn{\theta} is then not identified (Brynjarsdóttir and O'Hagan 2014), and
#' the misfit of the nearest run of a coarse library, which a change of
#' \eqn{\theta} would remove, passes for a gap. With `orthogonal = TRUE` the
#' discrepancy is \eqn{P\delta}, \eqn{P} the projector off the outputs'
#' local sensitivities to \eqn{\theta} (the slopes of a linear fit of the
#' outputs on \eqn{\theta} over the runs nearest the one that fits the data
#' best), as Plumlee (2017) proposes: what \eqn{\theta} can explain is left
#' to \eqn{\theta}, and the Bayes factor weighs only what it cannot. On our
#' systems this removed the false gaps of libraries too coarse for the data
#' (log Bayes factors of 2 to 17 became -2 to -4) and kept real ones
#' decisive, at about half their log Bayes factor.
#'
#' **What you know about the gap.** `zero_at` and `flat_at` give settings
#' where \eqn{\delta} is known to be zero, and where its slope over every x
#' column is known to be zero (say, a machine that does no work at no load
#' and whose first response to it the simulator gets right). Both are exact
#' observations of the Gaussian process, so \eqn{\delta} given them is
#' again a Gaussian process, with kernel \eqn{K^* = K - K_{\cdot Z} M^{+}
#' K_{Z \cdot}} (\eqn{Z} the stacked value and slope observations, \eqn{M}
#' their covariance, from the kernel's derivatives): the evidence, the
#' posterior of \eqn{\delta} and [predict()] all use \eqn{K^*} and stay
#' exact. This is the remedy of Brynjarsdóttir and O'Hagan (2014): a
#' discrepancy that cannot be anything near the known settings can no longer
#' imitate a change of \eqn{\theta}, so \eqn{\theta} is the physical
#' value again, as Kennedy and O'Hagan define it. So with knowledge the
#' discrepancy is not orthogonal unless `orthogonal = TRUE` is asked for
#' (the projection would give back to \eqn{\theta} what the knowledge
#' takes from it; asked for, it projects the conditioned process). The
#' settings need not be among the data's (the simple machine's \eqn{x = 0}
#' is not). Wrong knowledge costs evidence: compare
#' [posterior_exact()]'s `log_evidence` with and without it (on the simple
#' machine, \eqn{\delta = 0} at \eqn{x = 1} and 4, which no \eqn{\theta}
#' makes true, lowered it by 6.7 to 9.7 against the same discrepancy without
#' knowledge, in 10 of 10 seeds). Knowledge that some \eqn{\theta} makes
#' true cannot be refuted by the data: a single wrong zero moves
#' \eqn{\theta} to the value that makes it true, at no cost in evidence.
#' With `noise_groups`, every group's discrepancy is conditioned on all the
#' knowledge. A scaled discrepancy (`scaled = TRUE`) favours a small
#' \eqn{\delta}, and so pulls \eqn{\theta} back towards the best fit even
#' with knowledge: on the simple machine its interval missed 0.65 in 10 of
#' 10 seeds with the lengths up to 1, and held it in 8 of 10 with the
#' default grid that knowledge brings (up to 3, see Length scales). For the simple
#' machine (simulator \eqn{\theta x}, reality \eqn{\theta x / (1 + x/20)},
#' \eqn{\theta = 0.65}, 11 settings on \[0.2, 4], noise sd 0.01) the 95%
#' interval of \eqn{\theta} held 0.65 in 10 of 10 noise seeds with
#' `zero_at = data.frame(x = 0), flat_at = data.frame(x = 0)` and in
#' 0 of 10 with the orthogonal default, which estimates the best-fitting
#' \eqn{\theta} (see the example and `bench/simple-machine-knowledge.R`).
#'
#' **Beyond the data.** [predict()] with a `simulator` carries \eqn{\delta}
#' to settings the field did not measure: its mean there weighs the
#' residuals at the measured settings by their correlation with the new
#' one, which decays with the distance over the length scale. So beyond the
#' measured range \eqn{\delta} reverts to its prior: its mean falls back to
#' 0 (the prediction to the simulator's) and its variance grows to the
#' prior's \eqn{\lambda K / \tau}, and the band for an extrapolation must be
#' wide: the data say nothing of the gap where no measurement was made but
#' its smoothness. A gap that keeps growing outruns the prior: on the simple
#' machine (below) the band for a new measurement at \eqn{x = 6}, half the
#' measured range beyond it, is about 9 times as wide as at \eqn{x = 4}
#' (the last measured setting), and knowledge (`zero_at`, `flat_at`), which
#' makes a gap that rises from zero learnable, is what lets it hold reality
#' there more often than not; see
#' `vignette("prediction")` for the coverage inside and outside the
#' measured range on two more systems.
#'
#' **Length scales.** The lengths are on x scaled to \[0, 1], so 1 is the
#' measured range. With `zero_at` or `flat_at` the default grid of
#' `length_x` also holds 3: pinned where it is known, a discrepancy with a
#' long length is a gap that rises smoothly from there, which the data can
#' learn and which carries on beyond the measured range. Measured
#' (`bench/length-grid.R`, `bench/length-grid-study.R`,
#' `bench/length-grid-gap.R`): on the simple machine, with knowledge, the
#' band at \eqn{x = 6} held reality in 9 of 10 noise seeds with 3 in the
#' grid, 4 of 10 without (at \eqn{x = 5}: 9 and 5), and \eqn{\theta}'s
#' interval held 0.65 in 10 of 10 either way, 0.076 wide instead of 0.096
#' (median); adding 10 as well changed nothing. On the beam of
#' `vignette("prediction")` the knowledge's band covered 86% of the held-out
#' measurements beyond the range instead of 81%. Without knowledge the
#' grid stays 0.1, 0.3, 1: there a length of 3 also helped extrapolation
#' (the default's band at \eqn{x = 6}: 8 of 10 instead of 5), but it is a
#' near-linear trend that competes with the gap screen's evidence
#' (`calibrate()` and [diagnose_gap()] use this default): on
#' `bench/gap-signal.R`'s drug curves the median log Bayes factor of a
#' 5-noise-sd gap fell from 1.18 to 0.92 and [diagnose_gap()] named a gap
#' in 2 of 45 trials without one instead of 1 (the warnings of
#' `calibrate()` were unchanged: 1 of 45, 13 of 15). Pass
#' `length_x = c(0.1, 0.3, 1, 3)` to extrapolate further without
#' knowledge.
#'
#' **Scaled (S-GaSP).** With `scaled = TRUE` the discrepancy is Gu and
#' Wang's (2018) scaled Gaussian process, as in RobustCalibration's default
#' `"S-GaSP"`: the process conditioned to have a small mean square over the
#' observed points, with kernel \eqn{K_z = K - K_{\cdot o}(K_{oo} +
#' (n/\lambda_z) I)^{-1} K_{o \cdot}} (\eqn{o} the \eqn{n} observed points)
#' and RobustCalibration's default \eqn{\lambda_z = (n \lambda \|1/\ell\|)^{1/2}}
#' (lengths over the existing axes), so that the discrepancy's mean square
#' grows like \eqn{\lambda^{1/2}}, not \eqn{\lambda}. It combines with
#' `orthogonal` (the projection first). Its kernel depends on the ratio, so
#' every ratio needs its own rotation (see Cost). On our
#' oscillator study it changed little (see `vignette("discrepancy")`), so it
#' is not the default.
#'
#' **Noise groups.** With `noise_groups`, the discrepancy acts within each
#' group (outputs of different groups, often different quantities in
#' different units, get independent discrepancies with the same
#' \eqn{\lambda} and \eqn{\ell}).
#'
#' **Replicates.** Replicated measurements share \eqn{\delta} at their
#' setting and have independent noise, so their scatter pins the noise and
#' separates it from the discrepancy (the cell means carry \eqn{R_g / r +
#' \lambda K}, the pure error carries noise only).
#'
#' **What a discrepancy can promise.** The Bayes factor answers *is there a
#' gap* reliably (decisively with replicated field data), and the posterior
#' of \eqn{\delta} shows where it lies. It cannot recover a physical
#' \eqn{\theta} that the missing effect imitates, even in part: then
#' \eqn{\theta} is the value that best fits the data together with a
#' discrepancy, not necessarily the physical one (Brynjarsdóttir and O'Hagan
#' 2014). A plain GaSP (`orthogonal = FALSE`) widens the intervals of
#' \eqn{\theta} around that best fit without restoring the coverage of the
#' physical value; the orthogonal default keeps them about as narrow as
#' without a discrepancy and states what \eqn{\theta} is, the best fit
#' (Plumlee 2017). On our oscillator study no discrepancy, GaSP or S-GaSP,
#' covered the physical frequency under a hardening spring; see
#' `vignette("discrepancy")`.
#'
#' **What theta means.** The three choices estimate different
#' \eqn{\theta}s, and `print()` and `summary()` of the fit, and its gap
#' warning, say which in one sentence. With the orthogonal default,
#' \eqn{\theta} is the best-fitting value, the \eqn{L_2} projection of Tuo
#' and Wu (2015): the \eqn{\theta} whose simulator output is closest to
#' reality over the observed settings. That is not what SEPIA, SAVE and
#' RobustCalibration report; compare those with `orthogonal = FALSE`, which
#' estimates Kennedy and O'Hagan's \eqn{\theta}, as they do: the value that
#' best fits the data together with the discrepancy, its meaning set by the
#' discrepancy's prior, and its intervals wider. With `zero_at` or `flat_at`
#' (which make `orthogonal` default to `FALSE`), \eqn{\theta} is the
#' physical value to the extent that the stated knowledge holds.
#'
#' **Which default.** Measured on four systems the package had not seen
#' (`bench/discrepancy-default.R`, 15 trials per arm: cooling with radiation
#' left out, a drug curve with a local second peak, the simple machine, and
#' growth with no gap on a fine and a coarse library; one experiment and 3
#' replicates): both choices weigh the same evidence (log Bayes factors
#' within 0.08 of each other). The orthogonal default covered the
#' best-fitting \eqn{\theta} in 115 of 120 trials with a gap, with intervals
#' 0.10 to 1.00 times as wide as without a discrepancy; `orthogonal = FALSE`
#' covered it in 120, at 1.0 to 14.8 times that width. Neither covered a
#' physical \eqn{\theta} that the gap imitates (0 of 60 each, as without a
#' discrepancy). Where the gap was local, the default's narrower interval
#' missed the physical \eqn{\theta} more often (53 of 60 against 59 of 60).
#' On the coarse library the default raised no gap warning in 30 trials,
#' `orthogonal = FALSE` 4. The cost is about the same (0.88 times
#' `orthogonal = FALSE`'s time, median). So the default stays orthogonal:
#' it says what \eqn{\theta} is and covers it with the narrowest intervals,
#' and the gap screen of [calibrate()] and [diagnose_gap()] rely on it to
#' keep a coarse library's misfit from passing for a gap. Use
#' `orthogonal = FALSE` to compare with SEPIA, SAVE or RobustCalibration, or
#' when you expect the gap to be local and want the wider interval; to
#' recover a physical \eqn{\theta}, state what you know (`zero_at`,
#' `flat_at`).
#'
#' **Cost.** The kernels enter through low-rank factors (their eigenvalues
#' above 1e-15 of the largest: \eqn{m}, tens over a grid of hundreds of
#' points). Per correlation grid point every run's residuals are whitened
#' and projected on one basis of all length scales (\eqn{O(N n m)}), each
#' length scale rotates those coordinates (\eqn{O(N m^2)}) and each ratio
#' then costs \eqn{O(N m)}. A scaled discrepancy's kernel depends on the
#' ratio, so there every ratio costs a rotation. A run predicted by an
#' emulator adds its error's rank \eqn{r} to the rotation, and
#' \eqn{O((m + r) r)} per run and ratio.
#'
#' @param ratio The grid of \eqn{\lambda}, the discrepancy's variance
#'   relative to the noise variance: non-negative values; 0 is the model
#'   without a discrepancy. The default spans a discrepancy with a standard
#'   deviation from 0.3 to 100 times the noise's, in half-decade steps.
#' @param length_x,length_t Grids of the length scales over the control
#'   settings (isotropic over the x columns) and over the output coordinate,
#'   both scaled to \[0, 1]: positive values whose squares neither underflow
#'   nor overflow (about 1.5e-154 to 1.3e154). Ignored when the library has a
#'   single x setting, or a single output per setting. `length_x = NULL`
#'   (the default) means 0.1, 0.3, 1, and also 3 with `zero_at` or `flat_at`
#'   (see Length scales in Details).
#' @param prior_none The prior probability of \eqn{\lambda = 0} (no
#'   discrepancy), in (0, 1), when `ratio` holds 0.
#' @param orthogonal Make the discrepancy orthogonal to the outputs' local
#'   sensitivities to \eqn{\theta}? See Details. `NULL` (the default) means
#'   `TRUE` without `zero_at` and `flat_at`, `FALSE` with either.
#' @param scaled Use the scaled Gaussian process (S-GaSP) of Gu and Wang
#'   (2018)? See Details.
#' @param zero_at,flat_at `NULL`, or data frames of settings where
#'   \eqn{\delta} is known to be zero (`zero_at`) and where its slope over
#'   every x column is known to be zero (`flat_at`): one column per x column
#'   of the library, named as there, and a column `t` when the library has
#'   several outputs per setting (a row per output coordinate where the
#'   knowledge holds for all); finite numbers, inside the data's range or
#'   not. See Details.
#' @return An object of class `griddy_discrepancy`, for the `discrepancy`
#'   argument of [calibrate()] and [posterior_exact()].
#' @references Kennedy, M. C. and O'Hagan, A. (2001). Bayesian calibration of
#'   computer models. *JRSS B* 63(3), 425-464.
#'
#'   Brynjarsdóttir, J. and O'Hagan, A. (2014). Learning about physical
#'   parameters: the importance of model discrepancy. *Inverse Problems*
#'   30(11), 114007.
#'
#'   Tuo, R. and Wu, C. F. J. (2015). Efficient calibration for imperfect
#'   computer models. *Annals of Statistics* 43(6), 2331-2352.
#'
#'   Plumlee, M. (2017). Bayesian calibration of inexact computer models.
#'   *JASA* 112(519), 1274-1285.
#'
#'   Gu, M. and Wang, L. (2018). Scaled Gaussian stochastic process for
#'   computer model calibration and prediction. *SIAM/ASA Journal on
#'   Uncertainty Quantification* 6(4), 1555-1583.
#' @seealso [discrepancy_evidence()]
#' @examples
#' gp_discrepancy()
#' ex <- griddy_example()
#' fit <- calibrate(ex$library, ex$field, n_iter = 1000, burn_in = 200, seed = 1,
#'                  discrepancy = gp_discrepancy(length_x = 1, length_t = c(0.3, 1)))
#' discrepancy_evidence(fit)
#'
#' # The simple machine (Brynjarsdóttir and O'Hagan 2014): the simulator
#' # theta x misses reality's theta x / (1 + x / 20), a gap that is zero and
#' # flat at x = 0. Told so, the discrepancy leaves theta = 0.65 identified.
#' x <- data.frame(x = seq(0.2, 4, length.out = 11))
#' theta <- data.frame(theta = seq(0.3, 1, by = 0.0025))
#' lib <- sim_library(theta, outer(theta$theta, x$x), x = x)
#' set.seed(1)
#' field <- field_data(matrix(0.65 * x$x / (1 + x$x / 20) + rnorm(11, sd = 0.01)), x = x)
#' known <- gp_discrepancy(zero_at = data.frame(x = 0), flat_at = data.frame(x = 0))
#' told <- posterior_exact(lib, field, discrepancy = known, joint = FALSE)
#' untold <- posterior_exact(lib, field, discrepancy = gp_discrepancy(), joint = FALSE)
#' # theta's 95% interval from the exact posterior over the runs
#' interval <- function(p) theta$theta[c(which(cumsum(p) >= 0.025)[1],
#'                                       which(cumsum(p) >= 0.975)[1])]
#' interval(told$run)    # holds 0.65
#' interval(untold$run)  # the best-fitting theta, below 0.65
#' @export
gp_discrepancy <- function(ratio = c(0, 10^seq(-1, 4, by = 0.5)),
                           length_x = NULL, length_t = c(0.1, 0.3, 1),
                           prior_none = 0.5, orthogonal = NULL, scaled = FALSE,
                           zero_at = NULL, flat_at = NULL) {
  zero_at <- assert_knowledge_frame(zero_at, "zero_at")
  flat_at <- assert_knowledge_frame(flat_at, "flat_at")
  # knowledge of delta is what identifies the physical theta; projecting
  # delta off theta's sensitivities would hand the gap's share back to theta
  knows <- !is.null(zero_at) || !is.null(flat_at)
  if (is.null(orthogonal)) orthogonal <- !knows
  # knowledge pins delta where it is known, so a long length scale (a gap
  # that rises smoothly from there) is learnable, and extrapolates further:
  # bench/length-grid.R
  if (is.null(length_x)) length_x <- if (knows) c(0.1, 0.3, 1, 3) else c(0.1, 0.3, 1)
  orthogonal <- assert_flag(orthogonal, "orthogonal")
  scaled <- assert_flag(scaled, "scaled")
  ratio <- sort(unique(assert_numeric_vector(ratio, "ratio")))
  if (any(!is.finite(ratio)) || any(ratio < 0)) {
    griddy_abort("`ratio` must hold finite values >= 0; received ", show_some(format(ratio)),
                 ".", class = "input")
  }
  lengths <- list(length_x = length_x, length_t = length_t)
  for (nm in names(lengths)) {
    v <- sort(unique(assert_numeric_vector(lengths[[nm]], nm)))
    if (any(!is.finite(v)) || any(v <= 0)) {
      griddy_abort("`", nm, "` must hold finite values > 0; received ", show_some(format(v)),
                   ".", class = "input")
    }
    # the kernel is exp(-d^2 / l^2): a square that underflows to 0 (or is
    # denormal) gives 0 / 0 on the diagonal, one that overflows a kernel of
    # ones whatever l
    bad <- v[!(v^2 >= .Machine$double.xmin & v^2 <= .Machine$double.xmax)]
    if (length(bad) > 0L) {
      griddy_abort("`", nm, "` must hold length scales whose squares are ordinary doubles ",
                   "(between ", format(sqrt(.Machine$double.xmin), digits = 3), " and ",
                   format(sqrt(.Machine$double.xmax), digits = 3), ", on coordinates ",
                   "scaled to [0, 1]); received ", show_some(format(bad)), ".",
                   class = "input")
    }
    lengths[[nm]] <- v
  }
  if (!is.numeric(prior_none) || length(prior_none) != 1L || !is.finite(prior_none) ||
      prior_none <= 0 || prior_none >= 1) {
    griddy_abort("`prior_none` must be a single number in (0, 1); received ",
                 paste(format(prior_none), collapse = ", "), ".", class = "input")
  }
  structure(c(list(ratio = ratio), lengths,
              list(prior_none = prior_none, orthogonal = orthogonal, scaled = scaled,
                   zero_at = zero_at, flat_at = flat_at)),
            class = "griddy_discrepancy")
}

#' @export
print.griddy_discrepancy <- function(x, ...) {
  cli::cat_line("<griddy_discrepancy> Gaussian-process discrepancy, ",
                length(x$ratio), " ratio(s) x ", length(x$length_x), " length_x x ",
                length(x$length_t), " length_t")
  cli::cat_line("  ratio (variance / noise variance): ", paste(format(x$ratio, digits = 3),
                                                               collapse = ", "))
  cli::cat_line("  length_x: ", paste(format(x$length_x), collapse = ", "),
                "; length_t: ", paste(format(x$length_t), collapse = ", "))
  if (isTRUE(x$orthogonal)) cli::cat_line("  orthogonal to the outputs' sensitivities to theta")
  if (isTRUE(x$scaled)) cli::cat_line("  scaled (S-GaSP): a small mean square favoured")
  if (!is.null(x$zero_at)) cli::cat_line("  known to be zero at ", nrow(x$zero_at), " setting(s)")
  if (!is.null(x$flat_at)) cli::cat_line("  known to be flat over x at ", nrow(x$flat_at),
                                         " setting(s)")
  if (any(x$ratio == 0)) cli::cat_line("  prior probability of no discrepancy: ", x$prior_none)
  invisible(x)
}

# What theta estimates under the discrepancy `discrepancy` (a
# gp_discrepancy(), or a fit's setup$discrepancy), in one sentence shared by summary(), print() and the
# gap warning; NULL for a fit without one (its gap warning says what theta
# is, gap_theta_sentence). An orthogonal discrepancy hands theta everything it
# can explain, so theta is the L2 projection (Tuo and Wu 2015, Plumlee 2017),
# whatever the knowledge; without the projection theta is Kennedy and
# O'Hagan's, set by the discrepancy's prior unless knowledge of the gap
# pins it (Brynjarsdottir and O'Hagan 2014).
theta_estimand <- function(discrepancy) {
  if (is.null(discrepancy)) return(NULL)
  # a fit's discrepancy points (discrepancy_points()) keep the choices on
  # their kernels; a fit made before they kept `orthogonal` was orthogonal
  # where it learnt sensitivities
  if (is.data.frame(discrepancy)) {
    kernels <- attributes(attr(discrepancy, "kernels"))
    if (is.null(kernels$orthogonal)) kernels$orthogonal <- !is.null(kernels$sensitivity)
    discrepancy <- kernels
  }
  if (isTRUE(discrepancy$orthogonal)) {
    return(paste0("With an orthogonal discrepancy (gp_discrepancy()'s default), theta is the ",
                  "best-fitting value, not the physical one: the L2 projection, the theta ",
                  "whose simulator output is closest to reality over the observed settings, ",
                  "and not the Kennedy-O'Hagan theta that SEPIA, SAVE and RobustCalibration ",
                  "report, which gp_discrepancy(orthogonal = FALSE) estimates."))
  }
  if (!is.null(discrepancy$zero_at) || !is.null(discrepancy$flat_at)) {
    return(paste0("With a discrepancy told what is known of the gap (zero_at, flat_at), theta ",
                  "is the best-fitting value under that knowledge, and so the physical value ",
                  "to the extent that the knowledge holds (Kennedy and O'Hagan's theta, with ",
                  "the discrepancy conditioned on it)."))
  }
  paste0("With a discrepancy that is not orthogonal (orthogonal = FALSE), theta is Kennedy ",
         "and O'Hagan's, as SEPIA, SAVE and RobustCalibration report it: the best-fitting ",
         "value together with the discrepancy, its meaning set by the discrepancy's prior, ",
         "not necessarily the physical one.")
}

# NULL, or a validated discrepancy.
assert_discrepancy <- function(discrepancy) {
  if (is.null(discrepancy)) return(NULL)
  if (!inherits(discrepancy, "griddy_discrepancy")) {
    griddy_abort("`discrepancy` must be NULL or made by gp_discrepancy(); received ",
                 class(discrepancy)[1], ".", class = "input")
  }
  discrepancy
}

# The discrepancy's grid points for a library: one row per point with its
# `ratio`, `length_x`, `length_t` (NA where the library has no such axis, and
# for ratio 0, whose covariance does not depend on them), `kernel` (the row
# of discrepancy_kernels(), 0 for ratio 0) and its log prior.
discrepancy_points <- function(discrepancy, library) {
  lx <- if (lib_n_x(library) > 1L) discrepancy$length_x else NA_real_
  lt <- if (lib_n_t(library) > 1L) discrepancy$length_t else NA_real_
  kernels <- expand.grid(length_x = lx, length_t = lt, KEEP.OUT.ATTRS = FALSE)
  positive <- discrepancy$ratio[discrepancy$ratio > 0]
  points <- data.frame(ratio = rep(positive, each = nrow(kernels)),
                       length_x = rep(kernels$length_x, length(positive)),
                       length_t = rep(kernels$length_t, length(positive)),
                       kernel = rep(seq_len(nrow(kernels)), length(positive)))
  if (isTRUE(discrepancy$scaled)) {
    # a scaled kernel depends on the ratio too: one kernel per point
    kernels <- points[c("length_x", "length_t", "ratio")]
    points$kernel <- seq_len(nrow(points))
  }
  has_none <- any(discrepancy$ratio == 0)
  prior_none <- if (length(positive) > 0L) discrepancy$prior_none else 1
  mass <- if (has_none) 1 - prior_none else 1
  points$log_prior <- rep(log(mass / max(nrow(points), 1L)), nrow(points))
  if (has_none) {
    none <- data.frame(ratio = 0, length_x = NA_real_, length_t = NA_real_, kernel = 0L,
                       log_prior = log(prior_none))
    points <- rbind(none, points)
  }
  # the directions a change of theta moves the outputs in, which an
  # orthogonal discrepancy leaves to theta (discrepancy_sensitivity())
  attr(kernels, "sensitivity") <- discrepancy$sensitivity
  # the observed points, over which a scaled discrepancy's mean square is kept small
  attr(kernels, "observed") <- discrepancy$observed
  # where delta and its slope are known to be zero (discrepancy-knowledge.R)
  attr(kernels, "zero_at") <- discrepancy$zero_at
  attr(kernels, "flat_at") <- discrepancy$flat_at
  # what theta then estimates (theta_estimand())
  attr(kernels, "orthogonal") <- discrepancy$orthogonal
  attr(points, "kernels") <- kernels
  points
}

# The discrepancy kernels K_l over every library output (library order:
# blocks of n_t per x setting), one per row of `kernels`: conditioned on what
# the user knows (zero_at, flat_at), then projected off the sensitivities to
# theta (orthogonal) and then scaled (S-GaSP) where the discrepancy asks for
# it. The knowledge is about delta itself, so it conditions the process
# before the projection: an orthogonal discrepancy is then P delta with
# delta conditioned.
discrepancy_kernels <- function(library, kernels) {
  d2 <- scaled_sq_distances(library)
  d2_x <- d2$x
  d2_t <- d2$t
  project <- sensitivity_projector(attr(kernels, "sensitivity"))
  knowledge <- knowledge_observations(library, attr(kernels, "zero_at"),
                                      attr(kernels, "flat_at"))
  cells <- if (!is.null(knowledge)) cell_observations(library)
  lapply(seq_len(nrow(kernels)), function(k) {
    kernel_at(kernels, k, d2_x, d2_t, cells, knowledge, project)
  })
}

# The kernel of grid point k of `kernels` over cells whose squared scaled
# distances are d2_x (between x settings) and d2_t (between t): squared
# exponential (constant along an axis without a length), conditioned on the
# knowledge at `cells`, projected (`project`) and scaled (S-GaSP) where the
# discrepancy asks. The fit's kernels and predict()'s at new settings
# (extended_kernels()) are both made here.
kernel_at <- function(kernels, k, d2_x, d2_t, cells, knowledge, project) {
  axis <- function(d2, len) if (is.na(len)) d2 * 0 + 1 else exp(-d2 / len^2)
  K <- kronecker(axis(d2_x, kernels$length_x[k]), axis(d2_t, kernels$length_t[k]))
  K <- condition_kernel(K, cells, knowledge, kernels$length_x[k], kernels$length_t[k])
  K <- project(K)
  if (is.null(kernels$ratio)) return(K)
  scaled_kernel(K, attr(kernels, "observed"),
                scaled_lambda_z(kernels$ratio[k], length(attr(kernels, "observed")),
                                c(kernels$length_x[k], kernels$length_t[k])))
}

# ---- a scaled discrepancy (S-GaSP) ---------------------------------------------

# Gu and Wang's (2018) scaled GaSP: delta conditioned on a small mean square
# over the n observed points o, which at finite n is the kernel
# K_z = K - K[, o] (K[o, o] + (n / lambda_z) I)^-1 K[o, ] (RobustCalibration's
# Get_R_z_new(), there over the observed points alone; here over every
# library output, so the posterior of delta and predictions see the same
# process). K_z <= K: the discrepancy's large, smooth components shrink most.
scaled_kernel <- function(K, observed, lambda_z) {
  K_o <- K[, observed, drop = FALSE]
  B <- K[observed, observed, drop = FALSE]
  diag(B) <- diag(B) + length(observed) / lambda_z
  K_z <- K - K_o %*% solve(B, t(K_o))
  (K_z + t(K_z)) / 2
}

# RobustCalibration's default lambda_z (post_sample_with_discrepancy()):
# sqrt(n |beta| / eta), beta the inverse lengths on unit-scaled inputs and
# eta the noise-to-discrepancy variance ratio, 1 / ratio here.
scaled_lambda_z <- function(ratio, n, lengths) {
  lengths <- lengths[!is.na(lengths)]
  inverse <- if (length(lengths) > 0L) sqrt(sum(1 / lengths^2)) else 1
  sqrt(n * inverse * ratio)
}

# ---- an orthogonal discrepancy ------------------------------------------------------

# A discrepancy that can imitate a change of theta competes with theta for
# the same misfit: theta is then not identified, and the misfit between a
# coarse library's runs (a change of theta too) passes for a gap. Plumlee's
# (2017) remedy: a discrepancy orthogonal to the outputs' sensitivities to
# theta. Here the sensitivities are the columns of G (library cells x
# parameters), the local linear slopes of the outputs near the best run;
# the discrepancy is P delta with P the projector off their span, so its
# covariance is P K P.
sensitivity_projector <- function(G) {
  if (is.null(G) || ncol(G) == 0L) return(identity)
  Q <- qr.Q(qr(G))
  function(K) {
    KQ <- K %*% Q
    K - KQ %*% t(Q) - Q %*% t(KQ) + Q %*% (crossprod(Q, KQ) %*% t(Q))
  }
}

# The discrepancy for these data: an orthogonal one learns the outputs'
# sensitivities to theta here, a scaled one the observed points (every
# problem with a discrepancy is built through this). `best`, when known, is
# best_fitting_run()'s answer.
discrepancy_for_data <- function(discrepancy, library, y, pattern, best = NULL) {
  assert_knowledge(discrepancy$zero_at, "zero_at", library)
  assert_knowledge(discrepancy$flat_at, "flat_at", library)
  if (isTRUE(discrepancy$scaled)) discrepancy$observed <- which(!is.na(y))
  if (!isTRUE(discrepancy$orthogonal)) return(discrepancy)
  discrepancy$sensitivity <- discrepancy_sensitivity(library, y, pattern, best)
  discrepancy
}

# G of the library for field data y (library order, NA where missing): the
# slopes of a linear fit of the outputs on theta (each column scaled to
# [0, 1]) over the 4p + 2 runs (at least 12) nearest the run that fits the
# data best (best_fitting_run()). Parameters the library holds constant, or
# that the nearest runs do not vary, are left out. NULL when none is left.
discrepancy_sensitivity <- function(library, y, pattern, best = NULL) {
  scale <- theta_scale(lib_theta(library))
  n_varying <- length(scale$cols)
  if (n_varying == 0L) return(NULL)
  if (is.null(best)) best <- best_fitting_run(library, y, pattern)
  k <- min(length(scale$cols[[1]]), max(4L * n_varying + 2L, 12L))
  # nearest_runs() over the runs that can be among the k nearest: those
  # whose distance by differences is within rounding of the k-th smallest
  # (nearest_runs() computes it another way, and its rounding breaks ties),
  # found in one read in C++: at 10^6 runs a search over every run in R
  # took half of calibrate()
  rows <- near_candidates_cpp(scale$cols, scale$span, as.integer(best), as.integer(k), 1e-9)
  scaled <- scaled_rows(scale, rows)
  at_best <- match(best, rows)
  near <- nearest_runs(scaled[at_best, , drop = FALSE], scaled, k)$idx[1, ]
  X <- sweep(scaled[near, , drop = FALSE], 2, scaled[at_best, ])
  X <- X[, apply(X, 2, function(v) diff(range(v)) > 0), drop = FALSE]
  if (ncol(X) == 0L) return(NULL)
  fit <- stats::lm.fit(cbind(1, X), lib_outputs(library, rows[near]))
  # lm.fit() drops a one-column response: a library of one output has a
  # vector of coefficients
  G <- t(matrix(as.matrix(fit$coefficients)[-1, , drop = FALSE], ncol(X)))
  G <- G[, colSums(!is.finite(G)) == 0L, drop = FALSE]
  if (ncol(G) == 0L) NULL else G
}

# The library's parameters that vary (their columns), with their smallest
# value and range, each read once.
theta_scale <- function(theta) {
  cols <- lapply(as.data.frame(theta), as.numeric)
  ranges <- vapply(cols, value_range_cpp, numeric(2))
  span <- ranges[2, ] - ranges[1, ]
  keep <- which(span > 0)
  list(cols = cols[keep], min = ranges[1, keep], span = span[keep])
}

# Rows `rows` of the varying parameters, each scaled to [0, 1] by its range
# over all runs (a matrix): column by column, the arithmetic of sweep()
# over the whole matrix (the same values).
scaled_rows <- function(scale, rows) {
  scaled <- lapply(seq_along(scale$cols),
                   function(j) (scale$cols[[j]][rows] - scale$min[[j]]) / scale$span[[j]])
  matrix(as.numeric(unlist(scaled, use.names = FALSE)), length(rows), length(scale$cols),
         dimnames = list(NULL, names(scale$cols)))
}

# The run that fits the field data best with independent noise (the noise
# pattern's sd and groups kept): one pass over the library.
best_fitting_run <- function(library, y, pattern) {
  setup <- correlation_setup(library, 0, 0, 2, pattern)
  which.min(misfit_parts(lib_quad_forms(library, y, setup))$C)
}

# The squared distances between the library's x settings (summed over the x
# columns, each scaled to [0, 1]) and between its t values (scaled so), on
# which the discrepancy's kernels are built.
scaled_sq_distances <- function(library) {
  x <- lib_x(library)
  d2_x <- if (lib_n_x(library) > 1L) {
    Reduce(`+`, lapply(x, function(v) outer(scale_unit(v), scale_unit(v), "-")^2))
  } else {
    matrix(0, 1, 1)
  }
  s <- scale_unit(lib_t(library))
  list(x = d2_x, t = outer(s, s, "-")^2)
}
