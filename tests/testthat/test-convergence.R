test_that("expected_tv is the exact mean of the TV distance of independent draws", {
  p <- c(0.5, 0.3, 0.15, 0.05)
  m <- 7
  # E|X/m - p| cell by cell, by summing over the binomial
  by_sum <- sum(vapply(p, function(q) {
    sum(stats::dbinom(0:m, m, q) * abs(0:m / m - q))
  }, numeric(1))) / 2
  expect_equal(expected_tv(p, m), by_sum)
  expect_equal(expected_tv(c(p, 0), m), by_sum)
  # large m: the normal approximation
  expect_equal(expected_tv(p, 1e5), expected_tv_iid(p, 1e5), tolerance = 0.01)
  # tiny cells: about 2 p e^{-m p} each, far below the normal approximation
  tiny <- c(0.999, rep(1e-5, 100))
  expect_lt(expected_tv(tiny, 100), expected_tv_iid(tiny, 100) / 5)
  expect_equal(expected_tv(1, 100), 0)
})

test_that("chain_rhat: NA for a constant parameter, Inf for chains stuck apart", {
  expect_true(is.na(chain_rhat(matrix(1, 10, 2))))
  expect_identical(chain_rhat(matrix(rep(c(0, 1), each = 10), 10, 2)), Inf)
  set.seed(1)
  expect_lt(chain_rhat(matrix(stats::rnorm(2000), 1000, 2)), rhat_threshold)
})

test_that("the Monte Carlo reference matches the observed TV of an exact sampler", {
  # one correlation grid point: the collapsed update draws theta independently
  # from the exact posterior, so the TV distance is Monte Carlo error alone
  toy <- toy_ar1(n_runs = 200, n_t = 30, sd = 0.3, lag_cor = 0)
  ratios <- vapply(1:5, function(s) {
    fit <- calibrate(toy$library, toy$field, n_iter = 1200, burn_in = 200, seed = s)
    a <- attr(summary(fit), "adequacy")
    expect_gt(a$effective_draws, 400)
    c(a$tv_distance, a$tv_reference)
  }, numeric(2))
  expect_equal(mean(ratios[1, ]) / mean(ratios[2, ]), 1, tolerance = 0.2)
})

stalled_toy <- function() {
  toy_ar1(n_runs = 100, n_t = 60, lag_cor = 0.9)
}
stall_grid <- c(0, 0.3, 0.6, 0.9)

# The thesis update on a rho grid of an AR(1) toy, expected to warn with
# `message`; returns the fit.
stalled_thesis_fit <- function(seed, message) {
  toy <- stalled_toy()
  expect_warning(
    fit <- calibrate(toy$library, toy$field, rho_t = stall_grid, n_iter = 1000, burn_in = 200,
                     chains = 2, update = "thesis", seed = seed),
    message, class = "griddy_warning_convergence")
  fit
}

test_that("thesis update stuck on one rho grid point: a convergence warning", {
  # both chains start at rho_t = 0, which the exact posterior gives 6e-6, and
  # never leave it (the thesis's tau-rho coupling, see ?calibrate): R-hat
  # sees nothing (rho_t is constant), the TV distance is 0.78 against a Monte
  # Carlo reference of 0.06
  fit <- stalled_thesis_fit(
    26, "total-variation distance from the exact posterior over runs, beyond Monte Carlo error")
  expect_true(all(fit$draws$grid_point == 1L))
  s <- summary(fit)
  a <- attr(s, "adequacy")
  expect_gt(a$tv_distance, 0.7)
  expect_lt(a$tv_reference, 0.1)
  expect_output(print(s), "Convergence: The draws are 0.7[0-9] in total-variation distance")
})

test_that("thesis chains stuck on different rho grid points: R-hat warns", {
  # chain 1 sits on rho_t = 0.9, chain 2 on rho_t = 0: R-hat of rho_t is
  # infinite (coda's gelman.diag gave about 10), and tau's is 1.8
  fit <- stalled_thesis_fit(
    14, "R-hat above 1.01 for theta \\([0-9.]+\\), tau \\([0-9.]+\\), rho_t \\(Inf\\)")
  s <- summary(fit)
  expect_true(all(s$rhat > rhat_threshold))
  expect_output(print(s), "Convergence: R-hat above 1.01")
})

test_that("a well-mixed collapsed fit gives no convergence warning or note", {
  toy <- stalled_toy()
  expect_no_warning(
    fit <- calibrate(toy$library, toy$field, rho_t = stall_grid, n_iter = 1000, burn_in = 200,
                     chains = 2, seed = 14),
    class = "griddy_warning_convergence")
  s <- summary(fit)
  expect_true(all(s$rhat < rhat_threshold))
  a <- attr(s, "adequacy")
  expect_lt(a$tv_distance, tv_ratio_threshold * a$tv_reference)
  expect_false(any(grepl("Convergence", utils::capture.output(print(s)))))
})

test_that("tv_beyond_reference needs both the ratio and the floor", {
  expect_true(tv_beyond_reference(0.3, 0.05))
  expect_false(tv_beyond_reference(0.04, 0.001))
  expect_false(tv_beyond_reference(0.3, 0.2))
  expect_false(tv_beyond_reference(0.3, NA))
})

test_that("the distance over the runs either posterior visits is the distance over all", {
  set.seed(11)
  exact <- c(0, 0.5, 0, 0.25, 0.25, 0, 0)
  for (run in list(c(2, 2, 4, 5), c(2, 3, 3, 7, 2, 1), rep(6L, 3))) {
    dense <- tabulate(run, nbins = length(exact)) / length(run)
    expect_equal(run_tv_distance(run, exact), sum(abs(dense - exact)) / 2)
    expect_equal(1 / sum(sampled_frequencies(run)$freq^2), 1 / sum(dense^2))
  }
  expect_equal(run_tv_distance(rep(6L, 3), exact), 1)
})

test_that("rank_rhat() and rank_ess_bulk() give posterior's rhat() and ess_bulk()", {
  set.seed(2)
  cases <- list(
    matrix(stats::rnorm(2000), 1000, 2),
    matrix(stats::rnorm(2001), 2001, 1),                       # odd: the middle draw left out
    matrix(sample(1:5, 3000, TRUE), 1000, 3),                  # ties, three chains
    matrix(cumsum(stats::rnorm(3000)), 3000, 1),               # a random walk
    matrix(stats::arima.sim(list(ar = -0.95), 4000), 2000, 2), # antithetic: the ESS cap
    matrix(c(rep(1, 9), 2), 5, 2),                             # folded draws all one value
    matrix(c(rep(c(1, -1), 5), 2, -2), 12, 1))                 # Geyer's sum stops at once
  for (m in cases) {
    expect_equal(rank_rhat(m), suppressWarnings(posterior::rhat(m)), tolerance = 1e-12)
    if (nrow(m) >= 6L) {
      expect_equal(rank_ess_bulk(m), suppressWarnings(posterior::ess_bulk(m)),
                   tolerance = 1e-12)
    }
  }
  # draws that are not all finite go to posterior itself
  m <- matrix(c(stats::rnorm(99), Inf), 50, 2)
  expect_identical(rank_rhat(m), posterior::rhat(m))
})

test_that("the diagnostics' shortcuts give the numbers of the general path", {
  set.seed(4)
  # discrete draws: ranks counted per value, as sorting all draws gives them
  m <- matrix(sample(c(0.3, 0.35, 0.4, 0.45), 4000, TRUE), 1000, 4)
  expect_identical(normal_scores(m, discrete = TRUE), normal_scores(m))
  # too many values for counting: the general path
  m <- matrix(stats::rnorm(400), 100, 4)
  expect_identical(normal_scores(m, discrete = TRUE), normal_scores(m))
  # one mvfft() over the chains, as fft() chain by chain
  m <- cbind(stats::rnorm(200), 1, cumsum(stats::rnorm(200)))
  one <- function(x) {
    n <- length(x)
    v <- stats::var(x)
    if (v == 0) return(rep(0, n))
    ac <- Re(stats::fft(abs(stats::fft(c(x - mean(x), rep.int(0, 2 * stats::nextn(n) - n))))^2,
                        inverse = TRUE)[seq_len(n)])
    ac / ac[1] * v * (n - 1) / n
  }
  expect_identical(chain_autocovariances(m), vapply(1:3, function(k) one(m[, k]), numeric(200)))
  # a fit's columns without its data.frame, shaped without split()
  ex <- griddy_example()
  fit <- suppressWarnings(calibrate(ex$library, ex$field, rho_t = c(0, 0.5), n_iter = 300,
                                    burn_in = 100, chains = 2, seed = 1),
                          classes = "griddy_warning_resolution")
  expect_identical(sampled_columns(fit), as.list(parameter_draws(fit)))
  shape <- chain_shaper(fit$draws$chain)
  expect_equal(shape(fit$draws$tau), chain_matrix(fit$draws$tau, fit$draws$chain),
               ignore_attr = TRUE)
  shuffled <- sample(nrow(fit$draws))
  expect_identical(chain_shaper(fit$draws$chain[shuffled])(fit$draws$tau[shuffled]),
                   chain_matrix(fit$draws$tau[shuffled], fit$draws$chain[shuffled]))
})

test_that("whole ranks take their normal scores from one table, half ranks their own", {
  set.seed(8)
  m <- matrix(c(stats::rnorm(397), 0.5, 0.5, 0.5), 100, 4)  # one tie of three, one of two
  m[2, 2] <- m[3, 3]
  n <- length(m)
  r <- rank(as.vector(m), ties.method = "average")
  expect_identical(as.vector(normal_scores(m)),
                   stats::qnorm((r - 3 / 8) / (n - 2 * 3 / 8 + 1)))
  expect_identical(rank_scores(n), stats::qnorm((seq_len(n) - 3 / 8) / (n + 1 / 4)))
})

test_that("continuous draws without ties take the table's scores, as ranks give them", {
  set.seed(9)
  m <- matrix(stats::rexp(3000), 1500, 2)
  n <- length(m)
  r <- rank(as.vector(m))
  expect_identical(as.vector(normal_scores(m)), stats::qnorm((r - 3 / 8) / (n - 2 * 3 / 8 + 1)))
})
