#' Exact grid posterior and marginal likelihood
#'
#' Because the library is discrete and the precision \eqn{\tau} has a
#' conjugate Gamma prior, the joint posterior over (library run, correlation
#' grid point) can be computed exactly: \eqn{\tau} is integrated out
#' analytically (Gamma-normal) and every run is weighed at every grid point.
#' It needs no sampling, so it is the reference for [calibrate()] and the basis
#' of model comparison.
#'
#' With data \eqn{y} of length \eqn{n} and \eqn{C_{ig} = (y - g_i)' R_g^{-1}
#' (y - g_i)}, the joint posterior is
#' \deqn{p(i, g \mid y) \propto \pi_i \pi_g |R_g|^{-1/2}
#'   (b + C_{ig}/2)^{-(a + n/2)}}
#' and the marginal likelihood is
#' \deqn{p(y) = \sum_{i,g} \pi_i \pi_g (2\pi)^{-n/2} |R_g|^{-1/2}
#'   \frac{b^a \, \Gamma(a + n/2)}{\Gamma(a) (b + C_{ig}/2)^{a + n/2}}.}
#'
#' With missing field data, \eqn{n} counts the observed points and \eqn{R_g}
#' is restricted to them; with noise groups, the likelihood and the constant
#' are products over the groups (see [calibrate()]), and with relative `sd`
#' (see [field_data()]) \eqn{|R_g|} is that of \eqn{S R_g S}.
#'
#' `posterior_exact()` is a generic: the default method takes a library and
#' field data (the arguments of [calibrate()]); the method for a
#' [calibrate()] fit gives the exact posterior of the fit's own problem; the
#' method for a [griddy_stream()] the exact posterior of the data the stream
#' has taken so far (the same object as `posterior_exact(library, all data
#' so far)`, with the stream's correlation grid, prior and weights).
#'
#' @inheritParams calibrate
#' @param library A [sim_library()] (or any griddy library); or a
#'   [calibrate()] fit; or a [griddy_stream()].
#' @param ... Further arguments of the methods: for a library, `field` and
#'   those below; for a fit or a stream, `joint` only (the others are the
#'   fit's or the stream's own).
#' @param joint Logical: keep the runs x grid points table of joint
#'   probabilities? It is as large as the misfit table C (8 GB at 10^6 runs x
#'   1,000 grid points); `FALSE` leaves it out (`joint` is then `NULL`) and
#'   keeps only the margins, computed in passes over C.
#' @return A list of class `griddy_exact` with elements
#'   * `run`: the posterior probability of each library row (summed over the
#'     correlation grid);
#'   * `grid`: the correlation grid, one row per grid point (the `grid` of a
#'     [calibrate()] fit, see [rho_grid()]), with a column `prob`: the
#'     posterior probability of each grid point;
#'   * `joint`: the runs x grid points matrix of joint probabilities (`NULL`
#'     with `joint = FALSE`);
#'   * `log_evidence`: the log marginal likelihood under the stated priors
#'     (`NA` when `prior$rate` is 0, an improper prior). With the default
#'     vague prior it is meaningful for comparing libraries or correlation
#'     structures on the same data, not as an absolute number.
#' @seealso [calibrate()], [griddy_stream()]
#' @examples
#' ex <- griddy_example()
#' exact <- posterior_exact(ex$library, ex$field)
#' head(sort(exact$run, decreasing = TRUE))
#' exact$log_evidence
#' # the margins only, without the table as large as C
#' margins <- posterior_exact(ex$library, ex$field, rho_t = c(0, 0.5), joint = FALSE)
#' margins$grid
#' # a stream's exact posterior is the batch one
#' s <- update(griddy_stream(ex$library, rho_t = c(0, 0.5)), y = ex$field)
#' all.equal(posterior_exact(s, joint = FALSE), margins)
#' @export
posterior_exact <- function(library, ...) UseMethod("posterior_exact")

#' @rdname posterior_exact
#' @export
posterior_exact.default <- function(library, field, rho_x = 0, rho_t = 0, prior = NULL,
                                    x_power = 2, run_weights = NULL, noise_groups = NULL,
                                    joint = TRUE, discrepancy = NULL, ...) {
  check_no_dots(...)
  joint <- assert_flag(joint, "joint")
  problem <- calibration_problem(library, field, rho_x, rho_t, prior, x_power, run_weights,
                                 noise_groups, discrepancy = discrepancy)
  exact_from_problem(problem, joint)
}

#' @rdname posterior_exact
#' @export
posterior_exact.griddy_fit <- function(library, joint = TRUE, ...) {
  check_no_dots(joint, ..., owner = "a fit")
  exact_from_problem(library, assert_flag(joint, "joint"))
}

#' @rdname posterior_exact
#' @export
posterior_exact.griddy_stream <- function(library, joint = TRUE, ...) {
  check_no_dots(joint, ..., owner = "a stream")
  stream_posterior(library, joint)
}

# An argument that no method takes (a misspelt one, or data given to a fit
# or a stream, which hold their own) is an error, not silently dropped. For
# a fit or a stream, `joint` comes first: data given in its place are named.
check_no_dots <- function(joint = TRUE, ..., owner = NULL) {
  own <- if (!is.null(owner)) paste0(" (", owner, " holds its own data, grid and priors)")
  if (!is.logical(joint)) {
    griddy_abort("posterior_exact() of ", owner, " takes `joint` (TRUE or FALSE) after it; ",
                 "received ", class(joint)[1], own, ".")
  }
  if (...length() == 0L) return(invisible())
  dots <- names(list(...))
  dots <- if (is.null(dots)) character() else dots[dots != ""]
  griddy_abort("posterior_exact()", if (!is.null(owner)) paste0(" of ", owner),
               " takes no further argument; received ",
               if (length(dots) > 0L) paste0("`", dots, "`", collapse = ", ") else
                 paste(...length(), "unnamed"), own, ".")
}

# The exact posterior of a calibration problem, or of a fit (which holds its
# problem). `joint = FALSE` leaves out the joint probabilities (NULL), a
# table as large as C, for callers that need only the margins. `post`: the
# problem's grid_posterior() when the caller has it already.
exact_from_problem <- function(problem, joint = TRUE, post = NULL) {
  if (is.null(post) || (joint && is.null(post$joint))) post <- grid_posterior(problem, joint)
  grid <- problem$grid
  grid$prob <- post$grid
  disc <- problem$setup$discrepancy
  structure(
    list(run = post$run, grid = grid, joint = post$joint, log_evidence = post$log_evidence),
    class = "griddy_exact", discrepancy = disc,
    # the grid points' masses in logs, which do not underflow (the Bayes
    # factor for a discrepancy reads them)
    log_grid_mass = if (!is.null(disc)) grid_log_mass(problem),
    # log p(y) up to the constant b^a of an improper prior (rate 0), which
    # models with the same prior share (the gap screen compares them)
    log_mass = post$log_mass
  )
}

#' @export
print.griddy_exact <- function(x, ...) {
  top <- order(x$run, decreasing = TRUE)[seq_len(min(5L, length(x$run)))]
  cli::cat_line("<griddy_exact> exact posterior over ", length(x$run), " runs x ",
                nrow(x$grid), " correlation grid point(s)")
  cli::cat_line("  effective number of runs: ", format(effective_count(x$run), digits = 3))
  cli::cat_line("  most probable runs: ", paste0(top, " (", format(x$run[top], digits = 3),
                                                 ")", collapse = ", "))
  cli::cat_line("  log evidence: ", format(x$log_evidence, digits = 6))
  invisible(x)
}
