test_that("resolution_table reports the marginal interval, effective values and edge mass", {
  theta <- data.frame(a = c(1, 2, 3, 1, 2), b = c(0, 0, 0, 1, 1))
  p <- c(0.025, 0.7, 0.025, 0, 0.25)
  tab <- resolution_table(p, theta)
  expect_identical(names(tab), c("parameter", "lower", "upper", "effective_values",
                                 "distinct_in_interval", "limited", "mass_at_min",
                                 "mass_at_max", "constant", "effective_runs", "pareto_k"))
  expect_identical(tab$parameter, c("a", "b"))
  # a: masses 0.025, 0.95, 0.025 on 1, 2, 3; 0.025 + 0.95 rounds below 0.975
  expect_equal(tab$effective_values[1], 1 / (2 * 0.025^2 + 0.95^2))
  expect_identical(c(tab$lower[1], tab$upper[1]), c(1, 2))
  expect_identical(tab$distinct_in_interval[1], 2L)
  expect_equal(c(tab$mass_at_min[1], tab$mass_at_max[1]), c(0.025, 0.025))
  # b: masses 0.75, 0.25
  expect_equal(tab$effective_values[2], 1 / (0.75^2 + 0.25^2))
  expect_identical(c(tab$lower[2], tab$upper[2]), c(0, 1))
  expect_equal(c(tab$mass_at_min[2], tab$mass_at_max[2]), c(0.75, 0.25))
  expect_identical(tab$limited, c(TRUE, TRUE))
  expect_identical(resolution_table(p, theta, min_values = 1.5)$limited, c(TRUE, FALSE))
  expect_identical(tab$constant, c(FALSE, FALSE))
  expect_identical(resolution_table(p, cbind(theta, c = 7))$constant, c(FALSE, FALSE, TRUE))
})

test_that("values within 1e-9 of the range count as one value", {
  theta <- data.frame(a = c(0, 1e-12, 0.5, 0.5 + 1e-11, 1, 1 - 1e-10))
  tab <- resolution_table(rep(1 / 6, 6), theta)
  expect_equal(tab$effective_values, 3)
  expect_equal(c(tab$mass_at_min, tab$mass_at_max), c(1 / 3, 1 / 3))
  expect_identical(tab$distinct_in_interval, 3L)
})

test_that("a Gaussian marginal has 3.5 s / h effective values; 10 keep its quantiles within s / 3", {
  s <- 1
  errors <- function(h) {
    vapply(seq(0, 0.95, by = 0.05), function(offset) {
      v <- seq(-8, 8, by = h) + offset * h
      p <- stats::dnorm(v, sd = s)
      tab <- resolution_table(p / sum(p), data.frame(x = v))
      expect_equal(tab$effective_values, 2 * sqrt(pi) * s / h, tolerance = 0.01)
      max(abs(c(tab$lower, tab$upper) - stats::qnorm(c(0.025, 0.975), sd = s)))
    }, numeric(1))
  }
  for (h in c(0.05, 0.1, 0.2, 0.3, 2 * sqrt(pi) / resolution_min_values)) {
    # resolved: a quantile is off by at most a step, little more than half a step in fact
    expect_lt(max(errors(h)), s / 3)
    expect_lt(max(errors(h)), 0.6 * h)
  }
  # limited (3.5 values at h = s): the quantiles can be off by half an sd
  expect_gt(max(errors(s)), s / 2)
})

test_that("in 11 dimensions only runs on a column's minimum or maximum are at its edge", {
  set.seed(3)
  n <- 1000
  theta <- as.data.frame(replicate(11, (sample(n) - stats::runif(n)) / n))
  # spread over interior runs: no flag, though every run is near some face
  centre <- exp(-rowSums((theta - 0.5)^2) / (2 * 0.2^2))
  interior <- resolution_table(centre / sum(centre), theta)
  expect_true(all(interior$mass_at_min <= 0.05 & interior$mass_at_max <= 0.05))
  expect_length(format_edges(interior), 0L)
  # on the maximum of column 4: that column only
  p <- numeric(n)
  p[which.max(theta$V4)] <- 1
  edge <- resolution_table(p, theta)
  expect_identical(edge$mass_at_max > 0.05, seq_len(11) == 4L)
  expect_true(all(edge$mass_at_min == 0))
  expect_identical(format_edges(edge), paste0(
    "V4: 100% of the posterior at the library's maximum; the truth may lie outside the ",
    "library's range of V4."))
})

test_that("resolution_limited uses the exact posterior over runs", {
  toy <- toy_xt(n_per_dim = 6)
  fit <- suppressWarnings(calibrate(toy$library, toy$field, n_iter = 300, burn_in = 100,
                                    seed = 1), classes = "griddy_warning_resolution")
  exact <- posterior_exact(toy$library, toy$field)$run
  expect_equal(resolution_limited(fit), resolution_table(exact, toy$library$theta))
  a <- library_adequacy(fit)
  expect_equal(a$parameters, resolution_table(exact, toy$library$theta))
  expect_equal(a$effective_runs, 1 / sum(exact^2))
  sampled <- tabulate(fit$draws$run, nbins = 36) / nrow(fit$draws)
  expect_equal(a$effective_runs_sampled, 1 / sum(sampled^2))
  expect_equal(a$tv_distance, tv_distance(sampled, exact))
})

test_that("format_adequacy has one line per limited parameter and per edge", {
  theta <- data.frame(k = 1:4, c = c(1, 2, 3, 4), z = 5)
  tab <- resolution_table(c(0, 0.3, 0.7, 0), theta)
  lines <- format_adequacy(list(parameters = tab, effective_runs = 1.7,
                                effective_runs_sampled = 1.8, tv_distance = 0.01))
  expect_match(lines[1], "effective number of runs 1.7 \\(sampled 1.8\\)")
  expect_match(lines[2], "total-variation distance 0.01")
  expect_identical(lines[-(1:2)], c(
    "z: constant in the library, not calibrated.",
    "k: interval limited by the library's resolution (1.7 effective values; 10 needed); see ?refine",
    "c: interval limited by the library's resolution (1.7 effective values; 10 needed); see ?refine"))
  spread <- resolution_table(rep(0.05, 20), data.frame(k = 1:20))
  lines <- format_adequacy(list(parameters = spread, effective_runs = 20,
                                effective_runs_sampled = 20, tv_distance = 0))
  expect_length(lines, 2L)
  # on one run both distances are rounding noise (printed as 7.1e-289)
  one <- format_adequacy(list(parameters = spread, effective_runs = 1, effective_runs_sampled = 1,
                              tv_distance = 7.1e-289, tv_reference = 1.4e-288,
                              effective_draws = 80000))
  expect_match(one[2], "distance < 0.0001 (Monte Carlo error alone: < 0.0001 at 80000", fixed = TRUE)
})

test_that("a posterior pressed against the edge of a scattered design is at its minimum", {
  # a Latin hypercube has one run at each column's minimum, which carried no
  # mass, so a posterior cut off by the range at its mode went unflagged
  set.seed(4)
  n <- 10000
  theta <- data.frame(a = (sample(n) - stats::runif(n)) / n, b = (sample(n) - stats::runif(n)) / n)
  p <- stats::dnorm(theta$a, sd = 0.05) * stats::dnorm(theta$b, mean = 0.5, sd = 0.1)
  tab <- resolution_table(p / sum(p), theta)
  expect_gt(tab$mass_at_min[1], 0.05)
  expect_lt(tab$mass_at_min[2], 0.05)
  expect_lt(tab$mass_at_max[2], 0.05)
  expect_match(format_edges(tab), "^a: .*library's minimum")
})

test_that("grouping only the runs with mass gives the table of every run", {
  # the table as it was computed over every run (commit c2e9769)
  every_run <- function(p, v, level = 0.95) {
    tol <- value_tolerance * (max(v) - min(v))
    group <- value_groups(v, tol)
    o <- order(v)
    values <- v[o][!duplicated(group[o])]
    mass <- as.vector(rowsum(p, group))
    bounds <- weighted_quantile(values, mass, c((1 - level) / 2, 1 - (1 - level) / 2))
    band <- max(tol, edge_band_share * (bounds[2] - bounds[1]))
    data.frame(lower = bounds[1], upper = bounds[2], effective_values = 1 / sum(mass^2),
               distinct_in_interval = sum(mass > 0 & values >= bounds[1] & values <= bounds[2]),
               mass_at_min = sum(p[v <= min(v) + band]), mass_at_max = sum(p[v >= max(v) - band]))
  }
  set.seed(6)
  n <- 5000
  scattered <- data.frame(a = stats::runif(n), b = stats::runif(n))
  grid <- expand.grid(a = seq(0, 1, length.out = 50), b = seq(0, 1, length.out = 100))
  for (theta in list(scattered, grid)) {
    # most runs underflow to probability 0, as on a large library
    lp <- -((theta$a - 0.3)^2 + (theta$b - 0.6)^2) / (2 * 0.002^2)
    p <- exp(lp - max(lp))
    p <- p / sum(p)
    expect_gt(mean(p == 0), 0.5)
    for (level in c(0.5, 0.95)) {
      tab <- resolution_table(p, theta, level = level)
      for (j in 1:2) {
        expect_identical(tab[j, names(every_run(p, theta[[j]]))],
                         `rownames<-`(every_run(p, theta[[j]], level), j))
      }
    }
  }
})

test_that("a summary saved before the `constant` column prints (chapter 5's shipped one failed)", {
  old <- data.frame(parameter = c("k", "c", "m"), effective_values = c(1, 1, 1),
                    limited = c(TRUE, TRUE, TRUE), mass_at_min = 0, mass_at_max = 0,
                    library_values = c(21L, 21L, 1L))
  lines <- format_adequacy(list(parameters = old, effective_runs = 1, tv_distance = 0.01,
                                tv_mc = 0.01, ess = 1000))
  expect_match(lines, "^m: constant in the library", all = FALSE)
  expect_match(lines, "^k: interval limited by the library's resolution", all = FALSE)
  expect_false(any(grepl("^m: interval limited", lines)))
})

test_that("the table's frame is the one data.frame() makes", {
  cols <- list(parameter = c("a", "b"), lower = c(0.1, 0.2), n = 1:2, limited = c(TRUE, FALSE))
  expect_identical(columns_frame(cols), do.call(data.frame, cols))
  set.seed(3)
  theta <- data.frame(a = runif(200), b = rep(1, 200))
  p <- runif(200)^6
  tab <- resolution_table(p / sum(p), theta)
  expect_identical(attributes(tab)[c("names", "class", "row.names")],
                   attributes(data.frame(parameter = c("a", "b"),
                                         tab[names(tab) != "parameter"]))[c("names", "class",
                                                                           "row.names")])
})
