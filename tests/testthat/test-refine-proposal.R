# A proposal over [0, 2] x [0, 1]^3 x {5} (a constant column) with two
# components, built by hand.
toy_proposal <- function() {
  range <- rbind(c(0, 0, 0, 0, 5), c(2, 1, 1, 1, 5))
  varies <- range[2, ] > range[1, ]
  comps <- list(list(weight = 0.7, centre = rep(0.3, 4), chol = diag(0.05, 4)),
                list(weight = 0.3, centre = rep(0.7, 4), chol = diag(0.1, 4)))
  proposal <- list(range = range, varies = varies, components = comps, df = proposal_df,
                   defensive = proposal_defensive, inside = 1)
  proposal$inside <- mixture_mass_inside(proposal)
  proposal
}

test_that("a proposal's draws stay in the range and follow its density", {
  set.seed(1)
  proposal <- toy_proposal()
  names <- c("a", "b", "c", "d", "e")
  draws <- draw_proposal(4000, proposal, names)
  expect_identical(names(draws), names)
  expect_true(all(draws$a >= 0 & draws$a <= 2 & draws$d >= 0 & draws$d <= 1))
  expect_true(all(draws$e == 5))
  # the density integrates to one over the range (volume 2): a uniform
  # Monte Carlo estimate, and the mass of a sub-box against the draws in it
  u <- data.frame(a = stats::runif(2e5, 0, 2), b = stats::runif(2e5), c = stats::runif(2e5),
                  d = stats::runif(2e5), e = 5)
  dens <- proposal_density(proposal, u)
  expect_equal(2 * mean(dens), 1, tolerance = 0.05)
  sub <- u$a < 1 & u$b < 0.5
  expect_equal(2 * mean(dens * sub), mean(draws$a < 1 & draws$b < 0.5), tolerance = 0.05)
  expect_identical(proposal_density(proposal, data.frame(a = 3, b = 0.5, c = 0.5, d = 0.5,
                                                         e = 5)), 0)
})

test_that("the mixture gives each of two separated modes its own component", {
  set.seed(2)
  q <- 5
  u <- rbind(matrix(stats::rnorm(600 * q, 0.25, 0.02), ncol = q),
             matrix(stats::rnorm(400 * q, 0.75, 0.02), ncol = q))
  w <- rep(1 / 1000, 1000)
  comps <- weighted_components(u, w)
  centres <- t(vapply(comps, `[[`, numeric(q), "centre"))
  weights <- vapply(comps, `[[`, numeric(1), "weight")
  low <- rowMeans(centres) < 0.5
  expect_true(any(low) && any(!low))
  expect_equal(sum(weights[low]), 0.6, tolerance = 0.02)
  # no component spans both modes: each one's sd is near a mode's (0.02)
  sds <- vapply(comps, function(cmp) max(sqrt(diag(crossprod(cmp$chol)))), numeric(1))
  expect_lt(max(sds), 0.06)
})

test_that("tempering reaches the effective runs it aims at, and stops at beta = 1", {
  set.seed(3)
  log_lik <- -stats::rexp(500, 0.02)
  log_prior <- rep(-log(500), 500)
  t50 <- tempered_weights(log_lik, log_prior, 50)
  expect_lt(t50$beta, 1)
  expect_equal(1 / sum(t50$w^2), 50, tolerance = 0.01)
  expect_identical(tempered_weights(log_lik / 1e4, log_prior, 50)$beta, 1)
})

test_that("the proposal's log likelihood has the fit's value near the best run and Gaussian tails", {
  toy <- refine_toy()
  problem <- toy$fit
  ll <- collapsed_log_lik(problem$C, problem$n_obs, problem$setup$logdet, problem$prior)
  ll <- apply(sweep(ll, 2, problem$log_prior_grid, "+"), 1, log_sum_exp)
  light <- proposal_log_lik(problem)
  drop <- max(ll) - ll
  expect_identical(max(light), 0)
  expect_true(all(light <= -drop + 1e-9))
  near <- drop < 1
  expect_equal(light[near], -drop[near], tolerance = 0.05)
})

test_that("posterior mass far from every component of the last proposal is measured", {
  proposal <- toy_proposal()
  proposal$components <- proposal$components[1]
  proposal$components[[1]]$chol <- diag(0.01, 4)
  # runs at the component's centre, 2 of its sds off on each axis, and at
  # a second mode
  theta <- data.frame(a = c(0.6, 0.64, 1.8), b = c(0.3, 0.32, 0.9), c = c(0.3, 0.32, 0.9),
                      d = c(0.3, 0.32, 0.9), e = 5)
  expect_equal(far_mass(c(0.5, 0.3, 0.2), theta, proposal), 0.2)
  expect_identical(far_mass(c(0.5, 0.3, 0.2), theta, NULL), 0)
})

test_that("components are grouped into modes by separation", {
  proposal <- toy_proposal()
  # toy: centres 0.3 and 0.7 on all four axes, sds 0.05 and 0.1: 7 apart
  expect_identical(proposal_modes(proposal), c(1L, 2L))
  # a third component beside the first is the same mode; merged transitively
  proposal$components[[3]] <- list(weight = 0.1, centre = rep(0.33, 4), chol = diag(0.05, 4))
  expect_identical(proposal_modes(proposal), c(1L, 2L, 1L))
  proposal$components[[2]]$centre <- rep(0.4, 4)
  expect_identical(proposal_modes(proposal), c(1L, 1L, 1L))
})

test_that("each mode's effective runs are counted from its own runs", {
  proposal <- toy_proposal()
  set.seed(3)
  # 40 equally weighted runs at the first mode, 4 at the second (a mode
  # resting on few runs, as in bench/many-parameters.R bimodal-4 trial 10)
  u <- rbind(matrix(0.3 + stats::rnorm(160, sd = 0.01), 40),
             matrix(0.7 + stats::rnorm(16, sd = 0.01), 4))
  theta <- data.frame(a = 2 * u[, 1], b = u[, 2], c = u[, 3], d = u[, 4], e = 5)
  p <- c(rep(0.6 / 40, 40), c(0.37, 0.01, 0.01, 0.01))
  modes <- mode_resolution(p, theta, proposal)
  expect_equal(modes$mass, c(0.6, 0.4))
  expect_equal(modes$effective_runs[1], 40)
  expect_equal(modes$effective_runs[2], 1 / sum((c(0.37, 0.01, 0.01, 0.01) / 0.4)^2))
  expect_equal(modes$at[[2]], theta[41, ], ignore_attr = TRUE)
  # a mode under mode_min_mass is not a mode to resolve, and one mode is the
  # whole posterior
  p2 <- c(rep(0.99 / 40, 40), rep(0.0025, 4))
  expect_null(mode_resolution(p2, theta, proposal))
  expect_null(mode_resolution(p, theta, NULL))
  one <- proposal
  one$components <- one$components[1]
  expect_null(mode_resolution(p, theta, one))
})

test_that("refine() in 4 parameters follows the posterior and resolves it", {
  toy <- linear4_toy()
  fit <- toy$fit
  y <- toy$y
  expect_true(any(fit$resolution$limited))
  r <- suppressMessages(refine(fit, linear4_sim, max_runs = 8000, seed = 1))
  expect_identical(r$refinement$reason, "resolved")
  expect_false(is.null(lib_rounds(r$library)[[1]]$proposal))
  tab <- resolution_limited(r)
  expect_true(all(tab$effective_runs >= effective_runs_needed(4)))
  # the continuous posterior (flat prior, noise integrated): a t with
  # n - p degrees of freedom around the least-squares fit
  x <- seq(0, 1, length.out = 30)
  X <- cbind(1, cos(pi * x), cos(2 * pi * x), cos(3 * pi * x))
  ls <- stats::lm.fit(X, as.vector(y))
  s2 <- sum(ls$residuals^2) / (30 - 4)
  se <- sqrt(diag(solve(crossprod(X))) * s2)
  half <- stats::qt(0.975, 30 - 4) * se
  expect_equal(tab$upper - tab$lower, unname(2 * half), tolerance = 0.25)
  expect_true(all(abs((tab$lower + tab$upper) / 2 - ls$coefficients) < 0.25 * half))
})

test_that("separated modes are told from one mode split in two", {
  comp <- function(centre, sd) list(weight = 0.5, centre = centre, chol = diag(sd, 2))
  apart <- list(components = list(comp(c(0.2, 0.5), 0.01), comp(c(0.8, 0.5), 0.01)))
  split <- list(components = list(comp(c(0.48, 0.5), 0.01), comp(c(0.52, 0.5), 0.01)))
  expect_true(separated_modes(apart))
  expect_false(separated_modes(split))
  apart$components[[2]]$weight <- 0.01
  expect_false(separated_modes(apart))
  # one wide mode split by EM into a chain of narrow components: neighbours
  # are close, the chain's ends far apart; still one mode (every pair was
  # asked once, and the chain's ends called it two)
  chain <- list(components = lapply(seq(0.2, 0.8, by = 0.1), function(x) {
    cmp <- comp(c(x, 0.5), 0.03)
    cmp$weight <- 1 / 7
    cmp
  }))
  expect_true(components_apart(chain$components[[1]], chain$components[[7]]))
  expect_false(separated_modes(chain))
})

# An aliased oscillator: sampled at t = k pi / 2, frequencies w and w + 4
# give the same data, so the posterior has two modes of equal mass.
alias_sim <- function(theta) {
  tt <- (1:60) * pi / 2
  t(vapply(seq_len(nrow(theta)), function(i) {
    exp(-theta$c[i] * tt / 20) * sin(theta$w[i] * tt)
  }, numeric(60)))
}

test_that("refine() in two parameters keeps both modes of an aliased oscillator", {
  set.seed(5)
  n <- 1500
  theta <- data.frame(w = 1 + 6 * (sample.int(n) - stats::runif(n)) / n,
                      c = 0.5 + 1.5 * (sample.int(n) - stats::runif(n)) / n)
  lib <- sim_library(theta, alias_sim(theta))
  y <- alias_sim(data.frame(w = 1.8, c = 1.2)) + stats::rnorm(60, sd = 0.03)
  fit <- suppressWarnings(calibrate(lib, field_data(y, t = lib$t), n_iter = 500,
                                    burn_in = 100, seed = 1))
  r <- suppressWarnings(suppressMessages(refine(fit, alias_sim, max_runs = 3000, seed = 1)))
  expect_true(has_proposal_rounds(r$library))
  p <- r$exact$run
  w <- lib_theta(r$library)$w
  upper <- sum(p[w > 3.8])
  expect_gt(upper, 0.3)
  expect_lt(upper, 0.7)
  # scattered runs: the run-level test applies in two parameters
  expect_false(is.na(resolution_limited(r)$pareto_k[1]))
})

test_that("refine() resolves each of two modes, not only the whole posterior", {
  # bench/many-parameters.R's bimodal-4, trial 10: th1 enters as
  # 4 (th1 - 0.5)^2, so th1 and 1 - th1 fit equally and each mode holds half
  # the posterior. Resolving the whole alone stopped with the mirror mode on
  # 19.5 of 174 effective runs and 0.22 of the mass.
  set.seed(244)
  G <- matrix(stats::rnorm(320), 80, 4)
  H <- matrix(stats::rnorm(320), 80, 4)
  sim <- function(theta) {
    th <- as.matrix(theta)
    th[, 1] <- 4 * (th[, 1] - 0.5)^2
    sin(pi * th %*% t(G)) + 0.5 * exp(th %*% t(H) / 2)
  }
  lhs <- function(n) {
    u <- matrix(vapply(1:4, function(j) (sample.int(n) - stats::runif(n)) / n, numeric(n)), n)
    stats::setNames(as.data.frame(u), paste0("th", 1:4))
  }
  set.seed(2024)
  theta <- lhs(2000)
  lib <- sim_library(theta, sim(theta))
  set.seed(1010)
  truth <- unlist(lhs(1)) * 0.7 + 0.15
  truth[1] <- 0.5 + stats::runif(1, 0.15, 0.35)
  y <- sim(matrix(truth, 1))[1, ] + stats::rnorm(80, sd = 0.05)
  fit <- suppressWarnings(calibrate(lib, field_data(matrix(y, 1), t = lib$t), n_iter = 1000,
                                    burn_in = 200, seed = 10))
  r <- suppressMessages(refine(fit, sim, max_runs = 20000, seed = 10))
  expect_identical(r$refinement$reason, "resolved")
  state <- refine_state(r)
  expect_identical(unresolved_modes(state), integer())
  mirror <- sum(r$exact$run[lib_theta(r$library)$th1 < 0.5])
  expect_gt(mirror, 0.3)
  expect_lt(mirror, 0.7)
})
