test_that("edge runs are the extreme grid values, or the outer band of a Latin hypercube", {
  grid <- expand.grid(a = 1:5, b = 1:5)
  edge <- edge_runs(grid)
  expect_identical(sum(edge), 16L)
  expect_false(edge[grid$a == 3 & grid$b == 3])
  set.seed(1)
  lhs <- data.frame(a = sample(seq(0, 1, length.out = 100)), b = sample(seq(0, 1, length.out = 100)))
  edge <- edge_runs(lhs)
  # resolution 10 per dimension: half a step is 1/18 of the range
  expect_identical(edge, lhs$a <= 1 / 18 | lhs$a >= 17 / 18 | lhs$b <= 1 / 18 | lhs$b >= 17 / 18)
})

test_that("run_adequacy reports effective runs, edge mass and the top run", {
  theta <- data.frame(a = 1:4)
  a <- run_adequacy(c(0.1, 0.6, 0.3, 0), theta)
  expect_equal(a$effective_runs, 1 / (0.01 + 0.36 + 0.09))
  expect_equal(a$edge_mass, 0.1)
  expect_identical(a$top_run, 2L)
  expect_identical(a$top_theta$a, 2L)
  lines <- format_adequacy(list(sampled = run_adequacy(c(0, 0, 0.01, 0.99), theta),
                                exact = run_adequacy(c(0, 0, 0.01, 0.99), theta), tv_distance = 0))
  expect_match(lines, "sits on run 4", all = FALSE)
  expect_match(lines, "99% of the posterior lies on runs at the edge", all = FALSE)
})
