rho_t_grid <- c(0, 1e-6, 1e-3, 0.05)

test_that("the collapsed sampler reproduces the exact posterior over runs and rho", {
  toy <- toy_ar1()
  exact <- posterior_exact(toy$library, toy$field, rho_t = rho_t_grid)
  fit <- calibrate(toy$library, toy$field, rho_t = rho_t_grid, n_iter = 12000, burn_in = 1000,
                   chains = 2, seed = 42)
  m <- nrow(fit$draws)
  runs <- tabulate(fit$draws$run, nbins = 500) / m
  rhos <- tabulate(fit$draws$grid_point, nbins = 4) / m
  # Monte Carlo tolerance: 3 times the expected distance of independent draws,
  # with the draw count halved for autocorrelation (the collapsed theta draw
  # is exact given rho, so its integrated autocorrelation time is near 1).
  expect_lt(tv_distance(runs, exact$run), 3 * expected_tv_iid(exact$run, m / 2))
  expect_lt(tv_distance(rhos, exact$grid$prob), 3 * expected_tv_iid(exact$grid$prob, m / 2))
})

test_that("the thesis update targets the same posterior when it mixes", {
  toy <- toy_ar1(n_runs = 200, n_t = 30)
  exact <- posterior_exact(toy$library, toy$field)
  # AR(1) noise fitted as independent: the gap screen says so, rightly
  fit <- suppressWarnings(calibrate(toy$library, toy$field, n_iter = 12000, burn_in = 1000, update = "thesis", seed = 7), classes = "griddy_warning_gap")
  m <- nrow(fit$draws)
  runs <- tabulate(fit$draws$run, nbins = 200) / m
  # tau and theta are coupled in this update: allow an autocorrelation time of 4
  expect_lt(tv_distance(runs, exact$run), 3 * expected_tv_iid(exact$run, m / 4))
})

test_that("fits are reproducible and chains have their own streams", {
  toy <- toy_ar1(n_runs = 100, n_t = 20)
  run <- function(...) calibrate(toy$library, toy$field, rho_t = c(0, 0.1), n_iter = 500,
                                 burn_in = 100, chains = 2, ...)
  a <- run(seed = 1)
  b <- run(seed = 1)
  expect_identical(a$draws, b$draws)
  set.seed(99)
  c1 <- run()
  set.seed(99)
  c2 <- run()
  expect_identical(c1$draws, c2$draws)
  expect_false(identical(a$draws, c1$draws))
  expect_false(identical(a$draws$tau[a$draws$chain == 1], a$draws$tau[a$draws$chain == 2]))
  # a seed for one call leaves the caller's stream alone
  set.seed(5)
  before <- runif(1)
  set.seed(5)
  run(seed = 123)
  expect_identical(runif(1), before)
  # the progress bar's chunked calls draw the same numbers
  expect_identical(run(seed = 1, progress = TRUE)$draws, a$draws)
})

test_that("burn-in and thinning keep the right iterations", {
  toy <- toy_ar1(n_runs = 30, n_t = 10)
  fit <- suppressWarnings(
    calibrate(toy$library, toy$field, n_iter = 100, burn_in = 40, thin = 7, chains = 3, seed = 1),
    classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
  expect_identical(fit$draws$iteration, rep(seq(47L, 100L, by = 7L), 3))
  expect_identical(fit$draws$chain, rep(1:3, each = 8))
})

test_that("each kept tau is drawn at its own run and grid point", {
  toy <- toy_ar1(n_runs = 30, n_t = 10)
  fit <- suppressWarnings(
    calibrate(toy$library, toy$field, rho_t = c(0, 0.5), n_iter = 3000, burn_in = 0, seed = 3),
    classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
  # tau | run, grid point ~ Gamma(a + n/2, b + C/2): scaled by its rate, a Gamma(shape, 1)
  shape <- fit$prior$shape + fit$n_obs / 2
  u <- fit$draws$tau * (fit$prior$rate + fit$C[cbind(fit$draws$run, fit$draws$grid_point)] / 2)
  expect_equal(mean(u) / shape, 1, tolerance = 6 / sqrt(shape * length(u)))
  expect_equal(stats::var(u) / shape, 1, tolerance = 0.15)
})

test_that("the runtime covers the whole call, in parts", {
  toy <- toy_ar1(n_runs = 30, n_t = 10)
  elapsed <- system.time(fit <- suppressWarnings(
    calibrate(toy$library, toy$field, n_iter = 200, burn_in = 50, seed = 1)))[["elapsed"]]
  expect_named(fit$runtime, c("precompute", "sampling", "checks"))
  expect_true(all(is.finite(fit$runtime) & fit$runtime >= 0))
  # the parts do not overlap: together no more than the call took
  expect_lte(sum(fit$runtime), elapsed + 0.01)
  expect_match(fit_description(fit), paste0(format(sum(fit$runtime), digits = 3),
                                            " s in all (precompute "), fixed = TRUE)
})

test_that("the fit stores the exact margins that its methods read", {
  toy <- toy_ar1(n_runs = 30, n_t = 10)
  fit <- suppressWarnings(calibrate(toy$library, toy$field, rho_t = c(0, 0.5), n_iter = 200,
                                    burn_in = 50, seed = 1))
  exact <- posterior_exact(toy$library, toy$field, rho_t = c(0, 0.5), joint = FALSE)
  expect_identical(fit$exact, exact)
  expect_null(fit$exact$joint)
  # the methods read the stored margins: changed ones show through
  changed <- fit
  changed$exact$log_evidence <- -1
  changed$exact$run <- replace(numeric(30), 7, 1)
  expect_identical(as.numeric(logLik(changed)), -1)
  expect_identical(glance(changed)$effective_runs, 1)
  expect_identical(glance(changed)$log_evidence, -1)
  changed$resolution <- NULL
  expect_identical(resolution_limited(changed)$lower, unlist(toy$library$theta[7, ], use.names = FALSE))
  # the stored resolution table is that of the margins, read at level 0.95
  expect_identical(fit$resolution, resolution_table(exact$run, toy$library$theta))
  changed$resolution <- fit$resolution[0, ]
  expect_identical(nrow(resolution_limited(changed)), 0L)
  expect_identical(nrow(resolution_limited(changed, level = 0.9)), 1L)
  expect_identical(nrow(attr(summary(changed), "adequacy")$parameters), 0L)
  # a fit saved before the margins were stored recomputes them
  old <- fit
  old$exact <- NULL
  expect_identical(exact_margins(old), exact)
})

test_that("the fit stores its chains' diagnostics, the same as computed afresh", {
  toy <- toy_ar1(n_runs = 30, n_t = 10)
  fit <- suppressWarnings(calibrate(toy$library, toy$field, rho_t = c(0, 0.5), n_iter = 300,
                                    burn_in = 50, chains = 2, seed = 1))
  old <- fit
  old$diagnostics <- NULL
  expect_identical(fit$diagnostics, fit_diagnostics(old))
  expect_identical(summary(fit), summary(old))
  fresh <- draws_summary(parameter_draws(fit), fit$draws$chain, 0.95, type = 1)
  expect_identical(as.data.frame(summary(fit))[names(fresh)], fresh)
  expect_identical(fit$diagnostics$effective_draws,
                   min(nrow(fit$draws), fit$diagnostics$ess_bulk, na.rm = TRUE))
  # the stored ones are read: changed ones show through
  old$diagnostics <- fit$diagnostics
  old$diagnostics$rhat[] <- 2
  old$diagnostics$ess_bulk[] <- 7
  expect_warning(warn_convergence(old), class = "griddy_warning_convergence")
  expect_identical(unique(summary(old)$rhat), 2)
  theta <- names(toy$library$theta)
  expect_identical(unique(summary(old)$ess_bulk[summary(old)$parameter %in% theta]), 7)
})

test_that("with_seed() draws what the hand-written one of c2e9769 drew", {
  old_with_seed <- function(seed, code) {
    if (is.null(seed)) {
      return(code)
    }
    had_seed <- exists(".Random.seed", envir = globalenv(), inherits = FALSE)
    if (had_seed) old <- get(".Random.seed", envir = globalenv(), inherits = FALSE)
    on.exit(if (had_seed) {
      assign(".Random.seed", old, envir = globalenv())
    } else if (exists(".Random.seed", envir = globalenv(), inherits = FALSE)) {
      rm(".Random.seed", envir = globalenv())
    })
    set.seed(seed)
    code
  }
  draw <- function() list(sample.int(.Machine$integer.max, 3), stats::runif(2), stats::rgamma(2, 3))
  for (seed in list(1, 123456L, .Machine$integer.max)) {
    set.seed(8)
    new <- with_seed(seed, draw())
    after_new <- stats::runif(1)
    set.seed(8)
    old <- old_with_seed(seed, draw())
    expect_identical(new, old)
    expect_identical(after_new, stats::runif(1))
  }
  # NULL: the caller's stream
  set.seed(9)
  new <- with_seed(NULL, draw())
  set.seed(9)
  expect_identical(new, old_with_seed(NULL, draw()))
  # no stream before: none after
  withr::with_preserve_seed({
    rm(".Random.seed", envir = globalenv())
    with_seed(2, stats::runif(1))
    expect_false(exists(".Random.seed", envir = globalenv(), inherits = FALSE))
  })
  # a fit's chain seeds are the old function's
  toy <- toy_ar1(n_runs = 30, n_t = 10)
  fit <- suppressWarnings(calibrate(toy$library, toy$field, n_iter = 100, burn_in = 10,
                                    chains = 2, seed = 17))
  expect_identical(fit$seeds, old_with_seed(17, sample.int(.Machine$integer.max, 2)))
})

test_that("runs with zero prior weight are never drawn", {
  toy <- toy_ar1(n_runs = 50, n_t = 20)
  exact <- posterior_exact(toy$library, toy$field)
  w <- rep(1, 50)
  w[order(exact$run, decreasing = TRUE)[1:2]] <- 0
  for (u in c("collapsed", "thesis")) {
    fit <- suppressWarnings(
      calibrate(toy$library, toy$field, n_iter = 2000, burn_in = 0, seed = 2,
                update = u, run_weights = w),
      classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
    expect_false(any(fit$draws$run %in% which(w == 0)))
  }
})

test_that("calibrate validates its arguments before any C++ runs", {
  toy <- toy_ar1(n_runs = 20, n_t = 10)
  lib <- toy$library
  f <- toy$field
  expect_error(calibrate(lib, f, n_iter = 100, burn_in = 100), "`burn_in` \\(100\\) must be smaller than `n_iter` \\(100\\)")
  expect_error(calibrate(lib, f, n_iter = 100, burn_in = 50, thin = 60), "`thin` \\(60\\) keeps no draw")
  expect_error(calibrate(lib, f, chains = 0), "`chains`")
  expect_error(calibrate(lib, f, update = "gibbs"), class = "griddy_error_input", regexp = "`update` must be one of")
  expect_error(calibrate(lib, f, progress = "yes"), "`progress` must be TRUE or FALSE")
  expect_error(calibrate(lib, field_data(1:3)), "3 measurements but the library has")
  expect_error(calibrate(f, lib), "`library` must be a sim_library")
  expect_error(calibrate(lib, f, prior = list(shape = -1, rate = 1)), "prior\\$shape")
  expect_error(calibrate(lib, f, rho_t = -0.1), "`rho_t` must lie in")
})

test_that("a posterior finer than the library's spacing is flagged", {
  # 200 precise data on a 20-run library; the truth 0.395 lies between runs
  toy <- toy_ar1(n_runs = 20, n_t = 200, sd = 0.05, lag_cor = 0, theta_true = 0.395)
  expect_warning(fit <- calibrate(toy$library, toy$field, n_iter = 1000, burn_in = 200, seed = 1),
                 class = "griddy_warning_resolution",
                 regexp = "resolution: theta \\(1.0 effective values\\).*see \\?refine")
  # ... and rightly: the 95% interval misses the truth
  s <- summary(fit)
  expect_false(s$lower[1] <= 0.395 && 0.395 <= s$upper[1])
})

test_that("a posterior spread over many library values is not flagged", {
  # 10 noisy data on a 500-run library: the marginal spans ~100 values
  toy <- toy_ar1(n_runs = 500, n_t = 10, sd = 0.3, lag_cor = 0)
  expect_no_warning(fit <- calibrate(toy$library, toy$field, n_iter = 1000, burn_in = 200,
                                     seed = 1), class = "griddy_warning_resolution")
  tab <- resolution_limited(fit)
  expect_gt(tab$effective_values, 10)
  expect_gt(tab$distinct_in_interval, 10)
})

test_that("the resolution warning names every limited parameter, not a constant one", {
  toy <- toy_xt(n_per_dim = 4, sd = 0.1)
  lib <- toy$library
  expect_warning(calibrate(lib, toy$field, n_iter = 300, burn_in = 100, seed = 1),
                 class = "griddy_warning_resolution",
                 regexp = "a \\([0-9.]+ effective values\\), b \\([0-9.]+ effective values\\) are")
  one_b <- lib$theta$b == lib$theta$b[1]
  lib1 <- suppressWarnings(sim_library(lib$theta[one_b, ], lib$y[one_b, ], x = lib$x, t = lib$t))
  expect_warning(calibrate(lib1, toy$field, n_iter = 300, burn_in = 100, seed = 1),
                 class = "griddy_warning_resolution", regexp = "resolution: a \\([0-9.]+ effective values\\) is")
})

test_that("truncated theta draws equal the full draws for the same seed", {
  toy <- toy_ar1(n_runs = 500, n_t = 60, sd = 0.05)
  w <- rep(c(1, 2), 250)
  for (u in c("collapsed", "thesis")) for (weights in list(NULL, w)) {
    run <- function(tol) {
      withr_tol <- options(griddy.draw_tol = tol)
      on.exit(options(withr_tol))
      calibrate(toy$library, toy$field, rho_t = c(0, 0.5), n_iter = 3000, burn_in = 500,
                update = u, seed = 4, run_weights = weights)
    }
    full <- run(0)
    cut <- run(2^-53)
    # the truncation is real: draws reach fewer runs than the library holds ...
    expect_equal(unname(full$head_length), 500)
    expect_lt(max(cut$head_length), 400)
    # ... and is exact to 2^-53 per draw: identical chains (they could differ
    # with probability below 3000 * 2^-53 per chain)
    expect_identical(cut$draws, full$draws)
  }
})

test_that("the runs a collapsed draw leaves out hold less than the tolerance", {
  toy <- toy_ar1(n_runs = 500, n_t = 60, sd = 0.05)
  p <- local_problem(toy$library, toy$field, rho_t = c(0, 0.5, 0.9),
                     prior = list(shape = 1e-9, rate = 1e-9))
  shape_post <- 1e-9 + p$n_obs / 2
  for (tol in c(1e-3, 1e-8, 2^-53)) {
    h <- collapsed_heads_cpp(p$C, p$log_prior_run, shape_post, 1e-9, tol)
    for (g in seq_len(ncol(p$C))) {
      lw <- p$log_prior_run - shape_post * log(1e-9 + p$C[, g] / 2)
      w <- exp(lw - max(lw))
      head <- h$run[seq(h$start[g] + 1, h$start[g + 1])] + 1L
      # the head is a prefix of the runs sorted by C, with every run above tol / N
      expect_identical(head, order(p$C[, g])[seq_along(head)])
      expect_lt(sum(w[-head]) / sum(w), tol)
      cdf <- h$cdf[seq(h$start[g] + 1, h$start[g + 1])]
      expect_equal(cdf / cdf[length(cdf)], cumsum(w[head]) / sum(w[head]))
    }
  }
  # a loose tolerance gives shorter heads
  expect_lt(length(collapsed_heads_cpp(p$C, p$log_prior_run, shape_post, 1e-9, 1e-3)$run),
            length(collapsed_heads_cpp(p$C, p$log_prior_run, shape_post, 1e-9, 2^-53)$run))
})

test_that("the draw tolerance option is validated", {
  toy <- toy_ar1(n_runs = 20, n_t = 10)
  old <- options(griddy.draw_tol = -1)
  on.exit(options(old))
  expect_error(calibrate(toy$library, toy$field, n_iter = 100, burn_in = 10),
               "griddy.draw_tol")
})

test_that("chains on parallel future workers give the same draws", {
  skip_on_cran()
  skip_if_not_installed("future.apply")
  skip_if_not(installed_griddy_is_current(), "the installed griddy is not this version")
  toy <- toy_ar1(n_runs = 100, n_t = 20)
  run <- function() calibrate(toy$library, toy$field, rho_t = c(0, 0.1), n_iter = 500,
                              burn_in = 100, chains = 2, seed = 8)
  serial <- run()
  old <- future::plan(future::multisession, workers = 2)
  on.exit(future::plan(old))
  expect_identical(run()$draws, serial$draws)
})

test_that("a saved fit holds its library once", {
  toy <- toy_ar1(n_runs = 400, n_t = 200)
  # AR(1) noise fitted as independent: the gap screen says so, rightly
  fit <- suppressWarnings(calibrate(toy$library, toy$field, n_iter = 200, burn_in = 100, seed = 1), classes = "griddy_warning_gap")
  size <- function(v) length(serialize(v, NULL))
  rest <- fit
  rest$library <- NULL
  expect_lt(size(fit), size(rest) + size(toy$library) * 1.01)
  expect_lt(size(fit), 1.5 * size(toy$library))
  expect_null(fit$problem)
})

test_that("a sim_library edited after construction gets an R error, never reaches C++", {
  toy <- toy_ar1(n_runs = 41, n_t = 10)
  run <- function(lib) calibrate(lib, toy$field, n_iter = 50, burn_in = 10, seed = 1)
  lib <- toy$library
  lib$y[3, 4] <- NA
  expect_error(run(lib), class = "griddy_error")
  lib <- toy$library
  lib$y <- lib$y[, -1]
  expect_error(run(lib), class = "griddy_error_shape")
  lib <- toy$library
  lib$y <- rbind(lib$y, lib$y[1, ])
  expect_error(run(lib), class = "griddy_error_shape", regexp = "42 x 10")
  lib <- toy$library
  lib$theta <- lib$theta[-41, , drop = FALSE]
  expect_error(run(lib), class = "griddy_error_shape")
  lib <- toy$library
  lib$t <- NULL
  expect_error(run(lib), class = "griddy_error_shape")
})

test_that("a stop file ends a chain on a worker (what an interrupt writes)", {
  toy <- toy_ar1(n_runs = 30, n_t = 10)
  problem <- local_problem(toy$library, toy$field)
  control <- sampler_control(1000, 100, 1, 1, FALSE)
  inputs <- list(C = problem$C, tables = sampler_tables(problem, "collapsed"),
                 options = sampler_options(problem, "collapsed", control), tau_start = 1)
  stop_file <- withr::local_tempfile()
  expect_type(run_chain(1L, inputs, control, NULL, stop_file), "list")
  file.create(stop_file)
  expect_error(run_chain(1L, inputs, control, NULL, stop_file),
               class = "griddy_error_interrupted")
})

test_that("noise groups: tau_k draws follow Gamma(a + n_k/2, b + C_k/2), reproducibly", {
  toy <- toy_missing()
  prior <- list(shape = 2, rate = 0.5)
  by_t <- c("a", "a", "b", "b", "b")
  fit <- suppressWarnings(calibrate(toy$library, toy$field, rho_t = c(0.2, 0.7), prior = prior,
                                    noise_groups = by_t, n_iter = 4000, burn_in = 500, seed = 4))
  expect_identical(names(fit$draws), c("chain", "iteration", "run", "grid_point", "tau_a", "tau_b"))
  d <- as.data.frame(fit)
  expect_true(all(c("tau_a", "tau_b") %in% names(d)))
  expect_false("tau" %in% names(d))
  expect_identical(summary(fit)$parameter, c("k", "tau_a", "tau_b", "rho_t"))
  # conditional means: E[tau_k | run, g] = (a + n_k/2) / (b + C_k/2)
  sizes <- fit$setup$group_sizes
  expect_identical(unname(sizes), c(4L, 7L))
  expected <- matrix(0, nrow(fit$draws), 2)
  for (g in unique(fit$draws$grid_point)) {
    rows <- which(fit$draws$grid_point == g)
    expected[rows, ] <- t((prior$shape + sizes / 2) /
                            (prior$rate + t(run_group_forms(fit, fit$draws$run[rows], g)) / 2))
  }
  z <- (colMeans(fit$draws[c("tau_a", "tau_b")]) - colMeans(expected)) /
    (sqrt(colMeans(expected^2 / (prior$shape + sizes / 2))) / sqrt(nrow(d)))
  expect_true(all(abs(z) < 4))
  # the groups' C_k by dense algebra at one draw
  obs <- which(!is.na(toy$y))
  j <- 1
  g <- fit$draws$grid_point[j]
  R <- kronecker(diag(3), corr_t(toy$t, fit$grid$rho_t[g]))
  o <- intersect(obs, which(rep(by_t, 3) == "a"))
  r <- (toy$y - toy$Y[fit$draws$run[j], ])[o]
  expect_equal(run_group_forms(fit, fit$draws$run[j], g)[1, 1], drop(t(r) %*% solve(R[o, o], r)))
  # reproducible with seed and with set.seed
  again <- suppressWarnings(calibrate(toy$library, toy$field, rho_t = c(0.2, 0.7), prior = prior,
                                      noise_groups = by_t, n_iter = 4000, burn_in = 500, seed = 4))
  expect_identical(again$draws, fit$draws)
  set.seed(9)
  f1 <- suppressWarnings(calibrate(toy$library, toy$field, noise_groups = "x", n_iter = 300,
                                   burn_in = 100, prior = prior))
  set.seed(9)
  f2 <- suppressWarnings(calibrate(toy$library, toy$field, noise_groups = "x", n_iter = 300,
                                   burn_in = 100, prior = prior))
  expect_identical(f1$draws, f2$draws)
  expect_identical(grep("^tau", names(f1$draws), value = TRUE), c("tau_x1", "tau_x2", "tau_x3"))
})

test_that("the thesis update is refused with more than one noise group", {
  toy <- toy_missing()
  expect_error(calibrate(toy$library, toy$field, noise_groups = "x", update = "thesis",
                         n_iter = 100, burn_in = 10),
               "conditions on a single precision tau", class = "griddy_error_input")
  # one group, missing data: the thesis update runs
  fit <- suppressWarnings(calibrate(toy$library, toy$field, update = "thesis", n_iter = 200,
                                    burn_in = 10, seed = 1, prior = list(shape = 2, rate = 0.5)))
  expect_identical(fit$n_obs, 11L)
})

test_that("calibrate() with missing data samples the exact posterior over the observed points", {
  toy <- toy_missing()
  prior <- list(shape = 2, rate = 0.5)
  fit <- suppressWarnings(calibrate(toy$library, toy$field, rho_x = c(0, 0.5), rho_t = c(0.2, 0.7),
                                    prior = prior, n_iter = 6000, burn_in = 1000, seed = 3))
  ex <- posterior_exact(toy$library, toy$field, rho_x = c(0, 0.5), rho_t = c(0.2, 0.7),
                        prior = prior)
  freq <- tabulate(fit$draws$run, nbins = 8) / nrow(fit$draws)
  expect_lt(tv_distance(freq, ex$run), 0.05)
  expect_output(print(summary(fit), width = 200), "11 data points \\(4 missing\\)")
})

test_that("replicates: tau's posterior uses every measurement", {
  prior <- list(shape = 2, rate = 0.5)
  toy <- toy_replicates()
  fit <- without_resolution_warning(
    calibrate(toy$library, toy$field, prior = prior, n_iter = 4000, burn_in = 200, seed = 1))
  expect_identical(fit$n_obs, 28L)
  # E[tau | y] = sum_i p_i (a + n/2) / (b + RSS_i/2), RSS_i over all 28
  # measurements
  rss <- vapply(seq_len(nrow(toy$Y)), function(i) {
    sum((toy$y_rep - matrix(toy$Y[i, ], 3, byrow = TRUE)[toy$rows, ])^2, na.rm = TRUE)
  }, numeric(1))
  p <- posterior_exact(toy$library, toy$field, prior = prior)$run
  expect_equal(mean(fit$draws$tau), sum(p * (prior$shape + 14) / (prior$rate + rss / 2)),
               tolerance = 0.03)
  # with noise groups, each tau_k from its group's measurements
  by_t <- c("a", "a", "b", "b", "b")
  fit_g <- without_resolution_warning(
    calibrate(toy$library, toy$field, prior = prior, noise_groups = by_t, n_iter = 4000,
              burn_in = 200, seed = 1))
  in_a <- matrix(rep(by_t, 3) == "a", 3, byrow = TRUE)[toy$rows, ]
  rss_a <- vapply(seq_len(nrow(toy$Y)), function(i) {
    r <- toy$y_rep - matrix(toy$Y[i, ], 3, byrow = TRUE)[toy$rows, ]
    sum(r[in_a]^2, na.rm = TRUE)
  }, numeric(1))
  n_a <- sum(!is.na(toy$y_rep[in_a]))
  expect_identical(fit_g$setup$group_sizes, c(a = n_a, b = 28L - n_a))
  p_g <- posterior_exact(toy$library, toy$field, prior = prior, noise_groups = by_t)$run
  expect_equal(mean(fit_g$draws$tau_a),
               sum(p_g * (prior$shape + n_a / 2) / (prior$rate + rss_a / 2)), tolerance = 0.03)
})

test_that("replicates: summary counts measurements and cells; predict() is per measurement", {
  toy <- toy_replicates()
  fit <- without_resolution_warning(
    calibrate(toy$library, toy$field, n_iter = 2000, burn_in = 200, seed = 1))
  expect_output(print(summary(fit), width = 200),
                "28 data points at 15 measured cells \\(replicates\\)")
  pr <- predict(fit, ndraws = 2000, seed = 1)
  # the observed column holds the cell means
  expect_equal(pr$observed[1], mean(toy$y_rep[1:3, 1]))
  # the noise of one measurement: as wide at the thrice-replicated setting as
  # at the unreplicated one (a mean's would be 1/sqrt(3) as wide)
  width <- pr$pred_upper - pr$pred_lower
  expect_equal(mean(width[pr$x == 1]) / mean(width[pr$x == 2]), 1, tolerance = 0.1)
  expect_equal(mean(width), 2 * stats::qnorm(0.975) * sqrt(mean(1 / fit$draws$tau)),
               tolerance = 0.1)
})

test_that("the run order is the stable order of each column, on any number of threads", {
  set.seed(19)
  # ties, -0 and +0, and a column long enough for the radix sort
  C <- cbind(round(stats::runif(3000), 2), c(-0, 0, stats::rexp(2998)), stats::rexp(3000),
             sample(c(1, 2, 3), 3000, replace = TRUE))
  want <- apply(C, 2, function(v) order(v, method = "radix")) - 1L
  for (threads in 1:3) {
    expect_identical(run_order_cpp(C, threads), matrix(as.integer(want), nrow(C)))
  }
  # std::stable_sort below 256 runs
  expect_identical(run_order_cpp(C[1:100, ], 2L),
                   matrix(as.integer(apply(C[1:100, ], 2, order) - 1L), 100))
})

test_that("the collapsed heads do not depend on the number of threads", {
  toy <- toy_ar1(n_runs = 500, n_t = 60, sd = 0.05)
  p <- local_problem(toy$library, toy$field, rho_t = seq(0, 0.9, by = 0.1),
                     prior = list(shape = 1e-9, rate = 1e-9))
  one <- collapsed_heads_cpp(p$C, p$log_prior_run, 30, 1e-9, 2^-53, 1L)
  expect_identical(collapsed_heads_cpp(p$C, p$log_prior_run, 30, 1e-9, 2^-53, 2L), one)
})

test_that("the grid draws are the same with the runs' rows kept or computed each time", {
  toy <- toy_xt(n_per_dim = 6, n_t = 5)
  problem <- local_problem(toy$library, toy$field, rho_x = list(load = c(0, 0.4, 0.8), speed = 0.3),
                           rho_t = c(0, 0.3, 0.6))
  control <- sampler_control(3000, 100, 1, 1, FALSE)
  for (update in c("collapsed", "thesis")) {
    tables <- sampler_tables(problem, update)
    options <- c(sampler_options(problem, update, control), n_iter = 3000, first_iter = 1)
    chain <- function(keep_rows) {
      set.seed(4)
      gibbs_chain_cpp(problem$C, tables, c(options, keep_rows = keep_rows), 0L, 1)
    }
    expect_identical(chain(2^22), chain(0))
    expect_identical(chain(50), chain(0))  # room for a few runs only
  }
})

test_that("the chains' draws are the frame data.table made of them", {
  set.seed(5)
  chains <- lapply(1:3, function(i) {
    list(run = sample.int(50, 20, TRUE), grid_point = sample.int(3, 20, TRUE), tau = stats::rexp(20))
  })
  kept <- seq(12L, 50L, by = 2L)
  made <- as.data.frame(data.table::rbindlist(lapply(seq_along(chains), function(ch) {
    d <- chains[[ch]]
    list(chain = rep(ch, length(d$run)), iteration = kept, run = d$run,
         grid_point = d$grid_point, tau = d$tau)
  })))
  expect_identical(chain_draws(chains, kept), made)
  expect_identical(chain_draws(chains[1], kept), made[made$chain == 1L, , drop = FALSE])
})
