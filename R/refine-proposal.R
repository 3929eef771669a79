# refine()'s proposal in four or more parameters: where a round's new runs go
# when a box cannot hold the posterior (issue 24). A box of the marginals'
# ranges is mostly empty of posterior mass past three parameters (its volume
# grows like the product of the ranges while a correlated posterior's
# shrinks) and cannot hold two modes. A round instead draws its runs from a
# mixture fitted to the weighted library, as population Monte Carlo and
# adaptive multiple importance sampling do (Cappe et al. 2004, JCGS 13:907;
# Cornuet et al. 2012, Scand. J. Stat. 39:798):
#
# * one multivariate t component (df `proposal_df`) per component of a
#   Gaussian mixture fitted by weighted EM to the weighted runs, so that
#   separated modes each get one (weighted_components());
# * fitted to the posterior over runs tempered (its likelihood, at the best
#   run's noise level so that its tails stay Gaussian, raised to a power
#   beta <= 1: proposal_log_lik()) until it rests on `proposal_ess()`
#   effective runs: when the library is too coarse for the posterior (the
#   first rounds) the proposal is the wider tempered posterior, never a
#   covariance of one run, and it narrows round by round;
# * plus a defensive share (`proposal_defensive`) drawn uniformly over the
#   base library's range (Hesterberg 1995, Technometrics 37:185), so a mode
#   the components miss keeps receiving runs, and every run's prior weight
#   (prior over the deterministic mixture of all rounds' densities, see
#   design_density()) stays bounded.
#
# Everything is computed in unit coordinates u = (theta - lower) / width of
# the base library's range over its varying columns; constant columns keep
# their value. The mixture is truncated to the range (draws outside it are
# redrawn); its mass inside, `inside`, is estimated once per round from
# `proposal_mass_draws` draws, so the density is exact up to that estimate's
# relative error (about 0.5%).

# Parameters (varying) from which rounds use the proposal; below, the box
# Latin hypercube of refine_box() (validated in 2 and 3 parameters by
# bench/between-the-runs.R and bench/refine-max-runs.R).
proposal_min_parameters <- 4L

proposal_df <- 4
proposal_defensive <- 0.15
proposal_max_components <- 6L
proposal_mass_draws <- 50000L

# Effective runs the proposal is fitted to: enough for a p x p covariance
# per component (about 2p each) over a few components.
proposal_ess <- function(q) max(50, 10 * q)

# Below four parameters the proposal replaces the box only when its fit
# finds separated modes (separated_modes()), in libraries of at least this
# many runs (fewer cannot show two modes at the tempered level).
proposal_min_runs <- 200L

# Separated modes: two components of at least 5% of the mass each whose
# centres lie more than `mode_separation` apart in the Mahalanobis metric of
# their summed covariances (two Gaussians of equal spread that far apart
# have a deep density valley between them; components that split one mode
# lie a few units apart).
mode_separation <- 6

# Components are grouped as proposal_modes() groups them (transitively): a
# wide unimodal posterior split by EM into a chain of narrow components has
# ends far apart that are still one mode (on the one-parameter toy of
# test-refine.R, after a search round, every such fit called its chain two
# modes, and the rounds followed proposals where boxes resolve it).
separated_modes <- function(proposal) {
  comps <- Filter(function(cmp) cmp$weight >= 0.05, proposal$components)
  if (length(comps) < 2L) return(FALSE)
  max(proposal_modes(list(components = comps))) >= 2L
}

# Two components whose centres lie more than mode_separation apart in the
# metric of their summed covariances.
components_apart <- function(a, b) {
  d <- a$centre - b$centre
  sum(d * solve(crossprod(a$chol) + crossprod(b$chol), d)) > mode_separation^2
}

uses_proposal <- function(library) {
  range0 <- library_box(lib_base(library))
  sum(range0[2, ] > range0[1, ]) >= proposal_min_parameters
}

# ---- fitting -------------------------------------------------------------------

# The proposal of the next round from a refine state: list(range, varies,
# components = list(weight, centre, chol), df, defensive, inside, beta).
fit_proposal <- function(state) {
  problem <- state$problem
  library <- problem$library
  range0 <- library_box(lib_base(library))
  varies <- range0[2, ] > range0[1, ]
  u <- unit_coordinates(lib_theta(library), range0, varies)
  q <- ncol(u)
  tempered <- tempered_weights(proposal_log_lik(problem), problem$log_prior_run,
                               proposal_ess(q))
  w <- tempered$w
  # the runs that hold all but 0.1% of the tempered mass
  ord <- order(w, decreasing = TRUE)
  keep <- ord[seq_len(min(which(cumsum(w[ord]) >= 0.999)[1], 5000L))]
  components <- weighted_components(u[keep, , drop = FALSE], w[keep] / sum(w[keep]))
  # half the mixture local, to follow a curved or weakly identified band,
  # once the proposal is fitted to the posterior itself (refine-ridge.R)
  local <- if (tempered$beta == 1) {
    core <- ord[seq_len(which(cumsum(w[ord]) >= local_core_mass)[1])]
    local_components(u[core, , drop = FALSE], w[core] / sum(w[core]))
  }
  proposal <- list(range = range0, varies = varies, components = components,
                   df = proposal_df, defensive = proposal_defensive, inside = 1,
                   beta = tempered$beta, local = local,
                   local_share = if (length(local) > 0L) proposal_local_share else 0)
  proposal$inside <- mixture_mass_inside(proposal)
  proposal
}

# Each run's log likelihood for tempering, with light tails. The package's
# likelihood integrates the noise out, (b + C/2)^-a with a = shape + n/2:
# tempered, (b + C/2)^(-beta a) falls off like a power of the distance, so
# in many parameters a tempered posterior spreads over the whole range and
# the proposal fitted to it never narrows (issue 24: in 8 parameters, beta
# stayed near 0.1 and the proposal's sd near a quarter of the range over
# 20,000 runs). Its value at fixed noise, the misfit's best value,
# -a ((b + C/2) / (b + C_min/2) - 1) = -a (exp(-d / a) - 1) for d the log
# likelihood's drop from its best run, agrees with it near the best run
# and has Gaussian tails. Only the proposal uses it; the weights do not.
proposal_log_lik <- function(problem) {
  ll <- collapsed_log_lik(problem$C, problem$n_obs, problem$setup$logdet, problem$prior)
  ll <- if (is.matrix(ll)) {
    ll <- sweep(ll, 2, problem$log_prior_grid, "+")
    top <- do.call(pmax, as.data.frame(ll))
    top + log(rowSums(exp(ll - top)))
  } else ll
  a <- problem$prior$shape + sum(problem$n_obs) / 2
  drop <- pmax(max(ll) - ll, 0)
  -a * expm1(pmin(drop / a, 700))
}

# Tempered weights over runs: log w = log prior + beta * log likelihood,
# beta the largest in (0, 1] whose Kish ESS reaches `target` (1 when the
# posterior's own does).
tempered_weights <- function(log_lik, log_prior, target) {
  at <- function(beta) normalise_log(log_prior + beta * log_lik)
  if (effective_count(at(1)) >= target) return(list(w = at(1), beta = 1))
  lo <- 0
  hi <- 1
  for (i in 1:30) {
    mid <- (lo + hi) / 2
    if (effective_count(at(mid)) >= target) lo <- mid else hi <- mid
  }
  beta <- max(lo, 1e-6)
  list(w = at(beta), beta = beta)
}

# Components of a weighted sample (rows of u, weights w summing to 1): a
# Gaussian mixture fitted by weighted EM, started from k-means on a
# weighted resample (whitened by the sample's covariance). EM moves one
# component onto each separated mode; k-means alone, in the metric of a
# covariance that spans two modes, cut the sample along the other axes, and
# every component then spanned both modes (issue 24: a folded parameter
# kept a proposal a quarter of the range wide over 20,000 runs). Each
# component's covariance is shrunk toward the components' pooled one by q
# effective runs, so a component of few runs borrows their spread instead
# of collapsing.
weighted_components <- function(u, w) {
  q <- ncol(u)
  ess <- effective_count(w)
  k <- max(1L, min(proposal_max_components, floor(ess / (2 * q)), sum(!duplicated(u))))
  resp <- matrix(1, nrow(u), 1L)
  if (k > 1L) {
    cluster <- kmeans_clusters(u, w, k)
    resp <- outer(cluster, seq_len(max(cluster)), "==") + 0
  }
  for (step in seq_len(if (ncol(resp) > 1L) proposal_em_steps else 0L)) {
    resp <- mixture_responsibilities(u, mixture_components(u, w, resp))
  }
  mixture_components(u, w, resp)
}

proposal_em_steps <- 20L

kmeans_clusters <- function(u, w, k) {
  whole <- weighted_moments(u, w)
  white <- t(backsolve(chol(regularised_cov(whole$cov)), t(u) - whole$mean,
                       transpose = TRUE))
  pick <- sample.int(nrow(u), 2000L, replace = TRUE, prob = w)
  km <- tryCatch(stats::kmeans(white[pick, , drop = FALSE], centers = k, nstart = 3L,
                               iter.max = 30L),
                 error = function(e) NULL)
  if (is.null(km)) return(rep(1L, nrow(u)))
  d2 <- vapply(seq_len(k), function(j) colSums((t(white) - km$centers[j, ])^2),
               numeric(nrow(u)))
  cluster <- max.col(-matrix(d2, nrow(u)), ties.method = "first")
  match(cluster, sort(unique(cluster)))
}

# The M step: each component's weight, centre and covariance (Cholesky
# factor) from the responsibilities `resp` (runs x components); components
# with under a thousandth of the mass are dropped.
mixture_components <- function(u, w, resp) {
  q <- ncol(u)
  mass <- colSums(resp * w)
  resp <- resp[, mass > 1e-3 * sum(mass), drop = FALSE]
  parts <- lapply(seq_len(ncol(resp)), function(j) {
    rj <- resp[, j] * w
    m <- weighted_moments(u, rj / sum(rj))
    list(weight = sum(rj), centre = m$mean, cov = m$cov, ess = effective_count(rj / sum(rj)))
  })
  pooled <- regularised_cov(Reduce(`+`, lapply(parts, function(x) x$weight * x$cov)) /
                              sum(vapply(parts, `[[`, numeric(1), "weight")))
  lapply(parts, function(x) {
    cov <- (x$ess * x$cov + q * pooled) / (x$ess + q)
    list(weight = x$weight / sum(mass), centre = x$centre, chol = chol(cov))
  })
}

# The E step: each run's probability of each Gaussian component.
mixture_responsibilities <- function(u, comps) {
  q <- ncol(u)
  logs <- vapply(comps, function(cmp) {
    z <- backsolve(cmp$chol, t(u) - cmp$centre, transpose = TRUE)
    log(cmp$weight) - sum(log(diag(cmp$chol))) - colSums(z^2) / 2
  }, numeric(nrow(u)))
  logs <- matrix(logs, nrow(u))
  r <- exp(logs - do.call(pmax, as.data.frame(logs)))
  r / rowSums(r)
}

weighted_moments <- function(u, w) {
  mean <- colSums(u * w)
  centred <- sweep(u, 2, mean)
  list(mean = mean, cov = crossprod(centred * sqrt(w)))
}

# A covariance made positive definite by a small ridge (a millionth of its
# mean variance): the tempering above gives every fit at least
# proposal_ess() effective runs, so the covariance is the sample's own. A
# floor of the library's overall spacing would keep the proposal many
# posterior widths wide once the runs crowd around the posterior (issue 24:
# 20,000 runs in 4 parameters rested on 3 effective runs with one).
regularised_cov <- function(cov) {
  cov + diag(1e-6 * mean(diag(cov)) + 1e-14, ncol(cov))
}

# ---- drawing and density -----------------------------------------------------

# n runs from a proposal: the defensive share as a Latin hypercube over the
# range, the rest from the t mixture, redrawn until inside the range.
draw_proposal <- function(n, proposal, names) {
  n_def <- round(proposal$defensive * n)
  q <- sum(proposal$varies)
  u <- rbind(latin_hypercube_unit(n_def, q), draw_mixture_inside(n - n_def, proposal))
  u <- u[sample.int(nrow(u)), , drop = FALSE]
  stats::setNames(as.data.frame(from_unit(u, proposal$range, proposal$varies)), names)
}

latin_hypercube_unit <- function(n, q) {
  matrix(vapply(seq_len(q), function(j) (sample.int(n) - stats::runif(n)) / n, numeric(n)),
         n, q)
}

draw_mixture <- function(n, proposal) {
  comps <- all_components(proposal)
  q <- length(comps[[1]]$centre)
  which_comp <- sample.int(length(comps), n, replace = TRUE,
                           prob = vapply(comps, `[[`, numeric(1), "weight"))
  z <- matrix(stats::rnorm(n * q), n, q)
  scale <- sqrt(proposal$df / stats::rchisq(n, proposal$df))
  out <- matrix(0, n, q)
  for (j in unique(which_comp)) {
    at <- which_comp == j
    out[at, ] <- sweep((z[at, , drop = FALSE] %*% comps[[j]]$chol) * scale[at], 2,
                       comps[[j]]$centre, "+")
  }
  out
}

in_unit_cube <- function(u) rowSums(u >= 0 & u <= 1) == ncol(u)

draw_mixture_inside <- function(n, proposal) {
  if (search_boxes(proposal)) return(draw_search_boxes(n, proposal))
  q <- sum(proposal$varies)
  out <- matrix(0, 0, q)
  tries <- 0L
  while (nrow(out) < n) {
    need <- n - nrow(out)
    batch <- draw_mixture(ceiling(need / max(proposal$inside, 0.01)) + 10L, proposal)
    out <- rbind(out, batch[in_unit_cube(batch), , drop = FALSE])
    tries <- tries + 1L
    if (tries > 200L) {
      # the mixture hardly reaches the range: the rest uniformly (the
      # density below does not know it, so this must not happen in practice)
      griddy_abort("refine()'s proposal put almost no mass inside the library's range.",
                   class = "numeric")
    }
  }
  out[seq_len(n), , drop = FALSE]
}

mixture_mass_inside <- function(proposal) {
  mean(in_unit_cube(draw_mixture(proposal_mass_draws, proposal)))
}

# The proposal's density at theta rows (a data.frame or matrix of the
# library's columns), per unit of theta over the varying columns: the
# defensive uniform plus the t mixture truncated to the range.
proposal_density <- function(proposal, theta) {
  u <- unit_coordinates(theta, proposal$range, proposal$varies)
  width <- proposal$range[2, proposal$varies] - proposal$range[1, proposal$varies]
  inside <- in_unit_cube(u)
  mix <- if (search_boxes(proposal)) search_box_density(u, proposal) else
    exp(log_mixture_density(u, proposal))
  ((proposal$defensive + (1 - proposal$defensive) * mix / proposal$inside) * inside) /
    prod(width)
}

log_mixture_density <- function(u, proposal) {
  comps <- all_components(proposal)
  q <- ncol(u)
  nu <- proposal$df
  const <- lgamma((nu + q) / 2) - lgamma(nu / 2) - q / 2 * log(nu * pi)
  logs <- vapply(comps, function(cmp) {
    z <- backsolve(cmp$chol, t(u) - cmp$centre, transpose = TRUE)
    log(cmp$weight) + const - sum(log(diag(cmp$chol))) -
      (nu + q) / 2 * log1p(colSums(z^2) / nu)
  }, numeric(nrow(u)))
  logs <- matrix(logs, nrow(u))
  top <- do.call(pmax, as.data.frame(logs))
  top + log(rowSums(exp(logs - top)))
}

unit_coordinates <- function(theta, range, varies) {
  theta <- as.matrix(theta)[, varies, drop = FALSE]
  lower <- range[1, varies]
  width <- range[2, varies] - lower
  sweep(sweep(theta, 2, lower), 2, width, "/")
}

from_unit <- function(u, range, varies) {
  out <- matrix(range[1, ], nrow(u), ncol(range), byrow = TRUE)
  out[, varies] <- sweep(sweep(u, 2, range[2, varies] - range[1, varies], "*"), 2,
                         range[1, varies], "+")
  out
}

# ---- a mode the proposal misses ----------------------------------------------

# The posterior mass on runs far from every component of a proposal (beyond
# the 99.9% quantile of chi-square with q degrees of freedom in a
# component's metric, at 3 times its scale): a mode the last round's
# components did not cover, found by the defensive runs or the base library.
far_mass <- function(p, theta, proposal) {
  if (is.null(proposal)) return(0)
  held <- which(p > 0)
  u <- unit_coordinates(theta[held, , drop = FALSE], proposal$range, proposal$varies)
  q <- ncol(u)
  limit <- 9 * stats::qchisq(0.999, q)
  near <- Reduce(`|`, lapply(proposal$components, function(cmp) {
    z <- backsolve(cmp$chol, t(u) - cmp$centre, transpose = TRUE)
    colSums(z^2) <= limit
  }))
  sum(p[held][!near])
}

# ---- every mode resolved --------------------------------------------------------

# The whole posterior's effective runs can meet max(100, 20 p) while one of
# two modes rests on a handful: on a folded 4-parameter system (issue 24,
# bench/many-parameters.R bimodal-4, trial 10) the mirror mode held 19.5 of
# 174 effective runs, and its mass came out 0.22 where symmetry makes it
# 0.5. A mode's mass is estimated from its own runs' weights, so each mode
# must be resolved as a posterior of its own: at least as many effective
# runs within it as the whole would need. Modes holding under
# `mode_min_mass` are left to far_mass().
mode_min_mass <- 0.02

# Modes of a proposal: its components grouped, transitively, where they are
# not apart (components_apart()). An integer per component.
proposal_modes <- function(proposal) {
  comps <- proposal$components
  mode <- seq_along(comps)
  if (length(comps) < 2L) return(mode)
  pairs <- utils::combn(length(comps), 2L)
  for (ij in split(pairs, col(pairs))) {
    if (!components_apart(comps[[ij[1]]], comps[[ij[2]]])) mode[mode == mode[ij[2]]] <- mode[ij[1]]
  }
  match(mode, unique(mode))
}

# Each mode of the last proposal holding at least mode_min_mass of the
# posterior: data.frame(mass, effective_runs, at = its most probable run's
# theta, a list column), runs assigned to the mode of their most
# responsible component. NULL without a proposal or unless two modes hold
# that much.
mode_resolution <- function(p, theta, proposal) {
  if (is.null(proposal)) return(NULL)
  mode_of_component <- proposal_modes(proposal)
  if (max(mode_of_component) < 2L) return(NULL)
  held <- which(p > 0)
  u <- unit_coordinates(theta[held, , drop = FALSE], proposal$range, proposal$varies)
  owner <- max.col(mixture_responsibilities(u, proposal$components), ties.method = "first")
  mode <- mode_of_component[owner]
  out <- do.call(rbind, lapply(sort(unique(mode)), function(m) {
    pm <- p[held][mode == m]
    best <- held[mode == m][which.max(pm)]
    data.frame(mass = sum(pm), effective_runs = effective_count(pm / sum(pm)),
               at = I(list(theta[best, , drop = FALSE])))
  }))
  out <- out[out$mass >= mode_min_mass, , drop = FALSE]
  # one mode is the whole posterior, judged by the run-level test already
  if (nrow(out) < 2L) NULL else out
}

last_proposal <- function(library) {
  rounds <- lib_rounds(library)
  if (length(rounds) == 0L) return(NULL)
  rounds[[length(rounds)]]$proposal
}
