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
