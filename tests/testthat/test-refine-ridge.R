# A weighted sample along a quarter circle of radius 0.6 about the origin in
# the unit square (a curved band, thin across), its mass spread along the arc.
arc_sample <- function(n = 600, width = 0.005) {
  set.seed(35)
  angle <- stats::runif(n, 0.1, pi / 2 - 0.1)
  radius <- 0.6 + stats::rnorm(n, sd = width)
  u <- cbind(radius * cos(angle), radius * sin(angle))
  list(u = u, w = rep(1 / n, n), angle = angle)
}

test_that("local components at the ends of a curved band point along it", {
  s <- arc_sample()
  ends <- frontier_runs(s$u, s$w)
  # the runs at both ends of the arc are among the frontier
  expect_true(which.min(s$angle) %in% ends)
  expect_true(which.max(s$angle) %in% ends)
  set.seed(1)
  comps <- local_components(s$u, s$w, m = 10L)
  expect_length(comps, 10L + length(ends))
  expect_equal(sum(vapply(comps, `[[`, numeric(1), "weight")), 1)
  # each component's long axis follows the arc's tangent at its centre, and
  # it is far thinner across the arc than the whole sample is
  whole <- stats::cov(s$u)
  for (cmp in comps) {
    cov <- crossprod(cmp$chol)
    axis <- eigen(cov, symmetric = TRUE)$vectors[, 1]
    tangent <- c(-cmp$centre[2], cmp$centre[1]) / sqrt(sum(cmp$centre^2))
    expect_gt(abs(sum(axis * tangent)), 0.95)
    normal <- cmp$centre / sqrt(sum(cmp$centre^2))
    expect_lt(sum(normal * cov %*% normal), 0.05 * sum(normal * whole %*% normal))
  }
})

test_that("a proposal with local components draws from the density it states", {
  s <- arc_sample()
  set.seed(2)
  proposal <- list(range = rbind(c(0, 0), c(1, 1)), varies = c(TRUE, TRUE),
                   components = weighted_components(s$u, s$w), df = proposal_df,
                   defensive = proposal_defensive, inside = 1,
                   local = local_components(s$u, s$w), local_share = proposal_local_share)
  proposal$inside <- mixture_mass_inside(proposal)
  draws <- draw_proposal(20000, proposal, c("a", "b"))
  dens <- proposal_density(proposal, draws)
  # E_q[1 / q] is the volume of the range (1) when q is the density drawn from
  expect_equal(mean(1 / dens), 1, tolerance = 0.05)
})

test_that("a proposal's local components survive the file of a resumable refine()", {
  skip_if_not_installed("hdf5r")
  s <- arc_sample()
  set.seed(3)
  lib <- sim_library(data.frame(a = c(0, 1, 0.5), b = c(0, 1, 0.5)), matrix(0, 3, 2))
  proposal <- list(range = rbind(c(0, 0), c(1, 1)), varies = c(TRUE, TRUE),
                   components = weighted_components(s$u, s$w), df = proposal_df,
                   defensive = proposal_defensive, inside = 0.9, beta = 1,
                   local = local_components(s$u, s$w), local_share = proposal_local_share)
  file <- withr::local_tempfile(fileext = ".h5")
  store <- refine_store(file, lib)
  write_store_proposal(store, 1L, proposal)
  back <- read_store_proposal(store, 1L, lib)
  expect_length(back$local, length(proposal$local))
  expect_identical(back$local_share, proposal_local_share)
  theta <- data.frame(a = stats::runif(50), b = stats::runif(50))
  expect_equal(proposal_density(back, theta), proposal_density(proposal, theta))
})

test_that("an interval that creeps over several rounds is not resolved", {
  # each round moves the upper bound by an eighth of the width (below
  # interval_tol), so round-to-round stability holds, but over drift_rounds
  # rounds it moved by a quarter: a band explored step by step
  toy <- linear4_toy()
  state <- refine_state(toy$fit)
  state$table$limited[] <- FALSE
  state$far_mass <- 0
  step <- function(tab, k) {
    tab$upper <- tab$upper - k * (tab$upper - tab$lower) / 8
    tab
  }
  previous <- step(state$table, 1)
  expect_false(needs_round(state, previous, FALSE))
  expect_true(needs_round(state, previous, FALSE, earlier = step(state$table, 2)))
  expect_identical(drifted(state$table, step(state$table, 2)), !state$table$constant)
  expect_false(any(drifted(state$table, step(state$table, 1))))
})

test_that("refine() does not call a library resolved before it explored from the posterior", {
  toy <- linear4_toy()
  # a few rounds: the proposals are still tempered (no local components)
  w <- NULL
  r <- withCallingHandlers(
    suppressMessages(refine(toy$fit, linear4_sim, max_runs = 600, seed = 1)),
    griddy_warning_resolution = function(cnd) {
      w <<- cnd
      invokeRestart("muffleWarning")
    })
  expect_identical(r$refinement$reason, "max_runs")
  expect_false(explored(r$library))
  expect_s3_class(w, "griddy_warning_reach")
  expect_match(conditionMessage(w), "have not yet explored", fixed = TRUE)
})

test_that("more posterior beyond an earlier bound than Monte Carlo error allows is drift", {
  # a flat marginal (along a band) whose upper bound moved by a tenth of the
  # width: below interval_tol, but 10% of the posterior now lies beyond it
  theta <- data.frame(a = seq(0, 1, length.out = 2000), b = rep(c(0.4, 0.6), 1000))
  p <- rep(1 / 2000, 2000)
  tab <- resolution_table(p, theta)
  earlier <- tab
  earlier$upper[1] <- tab$upper[1] - (tab$upper[1] - tab$lower[1]) / 10
  expect_identical(drifted(tab, earlier), c(FALSE, FALSE))
  expect_identical(drifted(tab, earlier, p, theta), c(TRUE, FALSE))
  expect_identical(drifted(tab, tab, p, theta), c(FALSE, FALSE))
})

# An importance sample of a posterior flat along a product ridge, a b = 0.1
# for a in [0.1, 1] (b = 0.1 / a, thin across), from runs drawn along a
# with density proportional to `q` (on [0.1, 1]); weights 1 / q.
ridge_sample <- function(q, n = 3000) {
  set.seed(351)
  a <- stats::runif(20 * n, 0.1, 1)
  a <- a[stats::runif(20 * n) * max(q(a)) < q(a)][seq_len(n)]
  theta <- data.frame(a = a, b = 0.1 / a + stats::rnorm(n, sd = 0.002), c = 0.5)
  p <- (1 / q(a)) / sum(1 / q(a))
  list(theta = theta, p = p, table = resolution_table(p, theta, scattered = TRUE))
}

test_that("runs that thin out along a ridge before the posterior does are seen", {
  # runs drawn mostly near a = 0.1, thinning out by a = 0.6 while the ridge
  # goes on to 1: the few runs out there carry the tails' mass on uneven
  # weights, though the count of effective runs passes
  cut <- ridge_sample(function(a) stats::dnorm(a - 0.1, sd = 0.3))
  expect_gt(effective_count(cut$p), effective_runs_needed(2))
  expect_identical(thin_tails(cut$table, cut$p, cut$theta), c(TRUE, TRUE, FALSE))
  # drawn more densely towards both ends than the posterior (as refine()'s
  # heavier-tailed proposals are): the tails are not thin
  whole <- ridge_sample(function(a) 1 + 4 * ((a - 0.55) / 0.45)^2)
  expect_identical(thin_tails(whole$table, whole$p, whole$theta), c(FALSE, FALSE, FALSE))
  # boxes (below four parameters) keep their own tests
  expect_identical(thin_tails(cut$table, cut$p, cut$theta, applies = FALSE),
                   c(FALSE, FALSE, FALSE))
})

test_that("a parameter the data do not inform is not held by thin tails at its range's edges", {
  # chapter 5's nine Fiala parameters: seven keep their prior (flat over
  # the range), and runs drawn densest mid-range (as proposals fitted to
  # the informed parameters leave them) sample the edges thinly. An
  # interval spanning the range cannot be too narrow, so with the range
  # given it is not flagged; without it, it is (the check's own verdict).
  set.seed(352)
  a <- stats::rbeta(4000, 2, 2)
  theta <- data.frame(a = a, b = stats::runif(4000))
  p <- (1 / stats::dbeta(a, 2, 2)) / sum(1 / stats::dbeta(a, 2, 2))
  tab <- resolution_table(p, theta, scattered = TRUE)
  box <- rbind(c(0, 0), c(1, 1))
  expect_identical(thin_tails(tab, p, theta), c(TRUE, FALSE))
  expect_identical(thin_tails(tab, p, theta, range = box), c(FALSE, FALSE))
  # a range twice as wide: the interval spans half of it and is checked
  expect_identical(thin_tails(tab, p, theta, range = rbind(c(0, 0), c(2, 1))), c(TRUE, FALSE))
})

test_that("refine() on a product ridge does not stop resolved while its tails are thin", {
  # th1 and th2 enter only through th1 th2: a hyperbolic ridge in 4
  # parameters. Before the thin-tails check refine() stopped "resolved"
  # after 2,200 runs with no warning; the ridge's tails then rested on
  # fewer effective runs than their share, so it now runs on and says so.
  # (Here th1's interval was already within 3% of the exact one, [0.127,
  # 0.95] for th1 th2 = 0.12: the check's cost on a ridge, bench/README.md.)
  x <- seq(0, 1, length.out = 30)
  sim <- function(theta) {
    th <- as.matrix(theta)
    (th[, 1] * th[, 2]) %o% cos(pi * x) + th[, 3] %o% cos(2 * pi * x) + th[, 4] %o% (1 + 0 * x)
  }
  set.seed(4)
  theta <- lhs_theta4(500)
  lib <- sim_library(theta, sim(theta))
  y <- sim(matrix(c(0.3, 0.4, 0.6, 0.45), 1)) + stats::rnorm(30, sd = 0.02)
  fit <- suppressWarnings(calibrate(lib, field_data(y, t = lib$t), n_iter = 500, burn_in = 100,
                                    seed = 1))
  w <- NULL
  r <- withCallingHandlers(
    suppressMessages(refine(fit, sim, max_runs = 3000, seed = 1)),
    griddy_warning_resolution = function(cnd) {
      w <<- cnd
      invokeRestart("muffleWarning")
    },
    griddy_warning_convergence = function(cnd) invokeRestart("muffleWarning"))
  expect_identical(r$refinement$reason, "max_runs")
  expect_s3_class(w, "griddy_warning_reach")
  expect_match(conditionMessage(w), "th1 (the runs outside its interval are fewer", fixed = TRUE)
  expect_no_match(conditionMessage(w), "th3 (", fixed = TRUE)
  state <- refine_state(r)
  expect_identical(state_thin_tails(state), c(TRUE, TRUE, FALSE, FALSE))
})

# Runs along the product ridge a b = 0.1 (b = 0.1 / a, a in [0.1, 1]) and
# across it in c, in the unit box; log likelihood -(a b - 0.1)^2 / (2 s^2)
# - (c - 0.5)^2 / (2 s^2), flat along the ridge. The runs along a stop at
# `a_end`. Returns list(table, ll, theta, range).
open_ridge_case <- function(a_end, n = 3000, s = 0.01) {
  set.seed(352)
  a <- stats::runif(n, 0.1, a_end)
  theta <- data.frame(a = a, b = pmin(0.1 / a + stats::rnorm(n, sd = s / a), 1),
                      c = 0.5 + stats::rnorm(n, sd = s))
  ll <- -(theta$a * theta$b - 0.1)^2 / (2 * s^2) - (theta$c - 0.5)^2 / (2 * s^2)
  p <- exp(ll - max(ll)) / sum(exp(ll - max(ll)))
  list(table = resolution_table(p, theta, scattered = TRUE), ll = ll, theta = theta,
       range = rbind(c(0, 0, 0), c(1, 1, 1)))
}

test_that("runs that end along a ridge where the likelihood has not fallen leave it open", {
  # ridge-4 trials 11 and 18 (bench/ridge-systems.R at abb7bf2) stopped
  # "resolved", unwarned, with th2 at 0.79 and 0.80 of the reference's
  # width: the runs ended part way along the ridge and their tails were not
  # thin. Here the runs stop at a = 0.6 while the ridge goes on to a = 1
  cut <- open_ridge_case(0.6)
  expect_identical(open_ends(cut$table, cut$ll, cut$theta, cut$range), c(TRUE, TRUE, FALSE))
  # runs to the range's edge: the ridge ends there, nothing is open
  whole <- open_ridge_case(1)
  expect_identical(open_ends(whole$table, whole$ll, whole$theta, whole$range),
                   c(FALSE, FALSE, FALSE))
  # a Gaussian posterior: the likelihood falls at the runs' ends
  set.seed(353)
  theta <- data.frame(a = stats::rnorm(3000, 0.5, 0.05), b = stats::rnorm(3000, 0.4, 0.05))
  ll <- -((theta$a - 0.5)^2 + (theta$b - 0.4)^2) / (2 * 0.05^2)
  p <- exp(ll - max(ll)) / sum(exp(ll - max(ll)))
  tab <- resolution_table(p, theta, scattered = TRUE)
  expect_identical(open_ends(tab, ll, theta, rbind(c(0, 0), c(1, 1))), c(FALSE, FALSE))
  # boxes (below four parameters) keep their own tests
  expect_identical(open_ends(cut$table, cut$ll, cut$theta, cut$range, applies = FALSE),
                   c(FALSE, FALSE, FALSE))
})
