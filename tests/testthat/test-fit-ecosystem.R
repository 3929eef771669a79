# A fit with a sampled correlation parameter (rho_x_load) and a fixed one
# (rho_x_speed, rho_t), two chains, thinned. Its chains are short on purpose,
# so R-hat may pass 1.01 (it did, 1.012, with posterior from CRAN on a fresh
# machine): the convergence warning is muffled too.
eco_fit <- function(...) {
  toy <- toy_xt(n_per_dim = 4, n_t = 6)
  suppressWarnings(
    calibrate(toy$library, toy$field, rho_x = list(load = c(0, 0.5), speed = 0),
              n_iter = 300, burn_in = 100, thin = 2, chains = 2, seed = 1, ...),
    classes = c("griddy_warning_resolution", "griddy_warning_convergence"))
}

test_that("as_draws() and as_draws_df() hold the sampled parameters of as.data.frame()", {
  skip_if_not_installed("posterior")
  fit <- eco_fit()
  for (d in list(posterior::as_draws(fit), posterior::as_draws_df(fit))) {
    expect_s3_class(d, "draws_df")
    expect_identical(posterior::variables(d), c("a", "b", "tau", "rho_x_load"))
    expect_identical(posterior::nchains(d), 2L)
    expect_identical(posterior::niterations(d), 100L)
    ref <- as.data.frame(fit)
    ref <- ref[order(ref$chain, ref$iteration), ]
    for (p in c("a", "b", "tau", "rho_x_load")) expect_identical(d[[p]], ref[[p]])
    expect_identical(d$.chain, as.integer(ref$chain))
    expect_identical(d$.iteration, rep(1:100, 2))
    expect_identical(d$.draw, 1:200)
  }
})

test_that("the other draws formats and summarise_draws() work on a fit", {
  skip_if_not_installed("posterior")
  fit <- eco_fit()
  arr <- posterior::as_draws_array(fit)
  expect_identical(dim(arr), c(100L, 2L, 4L))
  expect_identical(as.vector(arr[, 2, "tau"]), fit$draws$tau[fit$draws$chain == 2])
  expect_s3_class(posterior::as_draws_list(fit), "draws_list")
  expect_identical(dim(posterior::as_draws_matrix(fit)), c(200L, 4L))
  expect_s3_class(posterior::as_draws_rvars(fit), "draws_rvars")
  s <- posterior::summarise_draws(fit)
  expect_identical(s$variable, c("a", "b", "tau", "rho_x_load"))
  sm <- summary(fit)
  expect_equal(as.numeric(s$mean), sm$mean)
  expect_true(all(c("rhat", "ess_bulk", "ess_tail") %in% names(s)))
})

test_that("coef() gives summary()'s estimate by default, or its medians or means", {
  fit <- eco_fit()
  # a and b: 98% of the draws on run 1, 2% on run 16, so their means lie
  # outside their 95% intervals and summary()'s estimate is the median
  fit$draws$run <- ifelse(seq_len(nrow(fit$draws)) %% 50 == 0, 16L, 1L)
  s <- summary(fit)
  expect_identical(s$estimate_type[1:2], c("median", "median"))
  expect_identical(coef(fit), stats::setNames(s$estimate, s$parameter))
  expect_identical(coef(fit, point = "median"), stats::setNames(s$median, s$parameter))
  expect_identical(coef(fit, point = "mean"), stats::setNames(s$mean, s$parameter))
  expect_false(identical(s$estimate, s$mean))
  # where the mean lies inside the interval, the one estimate is the mean
  expect_identical(s$estimate_type[3], "mean")
  expect_identical(coef(fit)[["tau"]], s$mean[3])
  expect_error(coef(fit, point = "mode"), class = "griddy_error_input")
})

test_that("confint() gives summary()'s intervals at any level and selects parameters", {
  fit <- eco_fit()
  for (level in c(0.5, 0.9, 0.95)) {
    s <- summary(fit, level = level)
    ci <- confint(fit, level = level)
    expect_identical(rownames(ci), s$parameter)
    expect_identical(unname(ci[, 1]), s$lower)
    expect_identical(unname(ci[, 2]), s$upper)
  }
  expect_identical(colnames(confint(fit)), c("2.5 %", "97.5 %"))
  expect_identical(colnames(confint(fit, level = 0.9)), c("5 %", "95 %"))
  expect_identical(confint(fit, "tau"), confint(fit)["tau", , drop = FALSE])
  expect_identical(confint(fit, 2:1), confint(fit)[c("b", "a"), ])
  expect_error(confint(fit, "k"), class = "griddy_error_input")
  expect_error(confint(fit, 5), class = "griddy_error_input")
  expect_error(confint(fit, level = 1.5), class = "griddy_error_input")
})

test_that("logLik() is the exact log evidence, and an error with an improper prior", {
  toy <- toy_xt(n_per_dim = 4, n_t = 6)
  prior <- list(shape = 2, rate = 0.5)
  fit <- eco_fit(prior = prior)
  ll <- logLik(fit)
  exact <- posterior_exact(toy$library, toy$field,
                           rho_x = list(load = c(0, 0.5), speed = 0), prior = prior)
  expect_s3_class(ll, "logLik")
  expect_equal(as.numeric(ll), exact$log_evidence)
  expect_identical(attr(ll, "df"), 4L)
  expect_identical(attr(ll, "nobs"), 18L)
  improper <- suppressWarnings(eco_fit(prior = list(shape = 1, rate = 0)))
  expect_error(logLik(improper), class = "griddy_error_improper_prior")
  expect_true(is.na(glance(improper)$log_evidence))
})

test_that("nobs() counts the observed points, without missing cells", {
  fit <- eco_fit()
  expect_identical(nobs(fit), 18L)
  toy <- toy_missing()
  miss <- suppressWarnings(calibrate(toy$library, toy$field, n_iter = 200, burn_in = 50,
                                     seed = 1))
  expect_identical(nobs(miss), 11L)
  expect_identical(glance(miss)$n_missing, 4L)
  rep <- toy_replicates()
  fit_rep <- suppressWarnings(calibrate(rep$library, rep$field, n_iter = 200, burn_in = 50,
                                        seed = 1))
  expect_identical(nobs(fit_rep), 28L)
})

test_that("tidy() has one row per parameter with summary()'s values", {
  fit <- eco_fit()
  td <- tidy(fit, conf.level = 0.9)
  s <- summary(fit, level = 0.9)
  expect_identical(names(td), c("term", "estimate", "std.error", "conf.low", "conf.high"))
  expect_identical(td$term, s$parameter)
  expect_identical(td$estimate, s$estimate)
  expect_identical(td$conf.low, s$lower)
  expect_identical(td$conf.high, s$upper)
  expect_equal(td$std.error, unname(vapply(parameter_draws(fit), stats::sd, 0)))
  expect_identical(tidy(fit, point = "mean")$estimate, s$mean)
  expect_identical(tidy(fit, conf.level = 0.9, point = "median")$estimate, s$median)
  expect_identical(names(tidy(fit, conf.int = FALSE)), c("term", "estimate", "std.error"))
  expect_identical(generics::tidy(fit), tidy(fit))
})

test_that("glance() is one row describing the fit", {
  fit <- eco_fit()
  g <- glance(fit)
  expect_identical(nrow(g), 1L)
  expect_identical(names(g), c("n_obs", "n_missing", "n_runs", "n_grid", "chains", "draws",
                               "log_evidence", "effective_runs", "effective_runs_sampled",
                               "runtime"))
  expect_identical(g$n_obs, 18L)
  expect_identical(g$n_runs, 16L)
  expect_identical(g$n_grid, 2L)
  expect_identical(g$chains, 2L)
  expect_identical(g$draws, 200L)
  expect_equal(g$log_evidence, as.numeric(logLik(fit)))
  adequacy <- attr(summary(fit), "adequacy")
  expect_equal(g$effective_runs, adequacy$effective_runs)
  expect_equal(g$effective_runs_sampled, adequacy$effective_runs_sampled)
})

test_that("griddy_koh has coef(), confint(), nobs() and tidy()", {
  set.seed(1)
  draws <- data.frame(iteration = 11:210, a = stats::rnorm(200), b = stats::runif(200),
                      sigma2 = stats::rexp(200))
  koh <- structure(list(draws = draws, parameters = c("a", "b"),
                        y_field = c(1, NA, 3, 4)), class = "griddy_koh")
  s <- summary(koh, level = 0.8)
  expect_identical(coef(koh), stats::setNames(summary(koh)$estimate, s$parameter))
  expect_identical(coef(koh, point = "median"), stats::setNames(s$median, s$parameter))
  expect_identical(coef(koh, point = "mean"), stats::setNames(s$mean, s$parameter))
  ci <- confint(koh, level = 0.8)
  expect_identical(unname(ci[, 1]), s$lower)
  expect_identical(unname(ci[, 2]), s$upper)
  expect_identical(colnames(ci), c("10 %", "90 %"))
  expect_identical(nobs(koh), 3L)
  td <- tidy(koh, conf.level = 0.8)
  expect_identical(td$term, c("a", "b"))
  expect_identical(td$estimate, s$estimate)
  expect_identical(td$conf.high, s$upper)
})
