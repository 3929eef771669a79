test_that("a posterior cut off by the last round's box is not resolved and reaches beyond it", {
  # the bug of the vignette's trial 130: a round's box that missed the truth
  # kept the posterior against its edge, and later boxes grew only by a
  # quarter of the (tiny) posterior width, so refine() ended narrow and wrong
  toy <- refine_toy()                          # truth k = 2.23
  box <- rbind(2.26, 2.6)
  theta_new <- data.frame(k = seq(2.26, 2.6, length.out = 200))
  problem <- extend_problem(toy$fit, theta_new, refine_sim(theta_new),
                            list(box = box, n = 200L, source = "simulator", error = NULL),
                            NULL)
  state <- refine_state(problem)
  expect_lt(state$table$lower, 2.26 + 0.1 * 0.34)        # against the box's lower edge
  expect_equal(unname(truncated_sides(state)), matrix(c(TRUE, FALSE), 2, 1))
  next_box <- refine_box(state)
  expect_lte(next_box[1, 1], 2.26 - 0.34)                # a whole box width beyond
  refined <- refine(toy$fit, refine_sim, max_runs = 2000, seed = 1)
  tab <- resolution_limited(refined)
  expect_true(tab$lower <= toy$k && toy$k <= tab$upper)
})

test_that("a box much wider than the posterior does not call an interior posterior cut off", {
  # the flip-flop of a 3-parameter trial (bench/refine-max-runs.R, osc3 seed
  # 2): a box reaching a whole width beyond one side ends a few posterior
  # widths past the interval on the other, within a tenth of the box's width,
  # so the next round reached beyond that side, and so on for 20,000 runs
  toy <- refine_toy()                          # truth k = 2.23
  box <- rbind(1.2, 2.33)
  theta_new <- data.frame(k = seq(1.2, 2.33, length.out = 800))
  problem <- extend_problem(toy$fit, theta_new, refine_sim(theta_new),
                            list(box = box, n = 800L, source = "simulator", error = NULL),
                            NULL)
  state <- refine_state(problem)
  tab <- state$table
  width <- tab$upper - tab$lower
  # interior: the box's edge is several interval widths past the interval,
  # yet within a tenth of the box's width
  expect_gt(2.33 - tab$upper, width)
  expect_lt(2.33 - tab$upper, 0.1 * (2.33 - 1.2))
  expect_false(any(truncated_sides(state)))
})
