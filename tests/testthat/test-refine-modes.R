# A folded system: th1 enters as 4 (th1 - 0.5)^2, so th1 and 1 - th1 fit
# equally (two modes of equal mass), on a coarse 7 x 7 grid whose runs
# nearest the truth (th1 = 0.75) lie at th1 = 1/3 and 2/3, either side of a
# worse column at th1 = 0.5: the base posterior shows both modes.
folded_sim <- function(theta) {
  t <- seq(0, 1, length.out = 30)
  th <- as.matrix(theta)
  g <- 4 * (th[, 1] - 0.5)^2
  outer(g, sin(2 * pi * t)) + outer(th[, 2], t)
}

folded_fit <- function() {
  grid <- expand.grid(th1 = seq(0, 1, length.out = 7), th2 = seq(0, 1, length.out = 7))
  lib <- sim_library(grid, folded_sim(grid))
  set.seed(3)
  y <- folded_sim(data.frame(th1 = 0.75, th2 = 0.4))[1, ] + rnorm(30, sd = 0.05)
  suppressWarnings(calibrate(lib, field_data(matrix(y, 1), t = lib$t), n_iter = 300,
                             burn_in = 100, seed = 1))
}

# The fit's problem with a box round of simulated runs in `box` (a 2 x 2
# matrix, rows lower and upper).
with_round <- function(problem, box, n = 150) {
  set.seed(4)
  theta <- latin_hypercube(n, box, c("th1", "th2"))
  extend_problem(problem, theta, folded_sim(theta),
                 list(box = box, proposal = NULL, n = n, source = "simulator", error = NULL),
                 NULL)
}

test_that("local maxima over the neighbour graph are found, the best first", {
  u <- matrix(seq(0, 1, length.out = 21))
  lw <- -pmin((u[, 1] - 0.25)^2 / 0.01, (u[, 1] - 0.8)^2 / 0.01 + 1)
  expect_equal(local_maxima(u, lw, 2L, -10, 8L), c(6L, 17L))
  # outside the window only the best
  expect_equal(local_maxima(u, lw, 2L, -0.5, 8L), 6L)
  expect_equal(local_maxima(u, lw, 2L, -10, 1L), 6L)
})

test_that("the base posterior's separated modes are its basins over the run graph", {
  fit <- folded_fit()
  modes <- base_modes(fit)
  big <- which(modes$share >= mode_lost_share)
  expect_length(big, 2L)
  expect_equal(sum(modes$share), 1, tolerance = 1e-3)
  expect_equal(modes$share[big[1]], modes$share[big[2]], tolerance = 1e-3)
  expect_equal(sort(vapply(modes$at[big], function(a) a$th1, numeric(1))), c(1, 2) / 3,
               tolerance = 1e-9)
})

test_that("a refinement that loses a base mode warns, one that keeps both does not", {
  fit <- folded_fit()
  modes <- base_modes(fit)
  one <- with_round(fit, rbind(c(0.6, 0.2), c(0.9, 0.6)))
  expect_warning(warn_mode_lost(modes, one, "simulator"), class = "griddy_warning_mode_lost")
  expect_warning(warn_mode_lost(modes, one, "simulator"), "th1 = 0.333")
  both <- with_round(with_round(fit, rbind(c(0.6, 0.2), c(0.9, 0.6))),
                     rbind(c(0.1, 0.2), c(0.4, 0.6)))
  expect_no_warning(warn_mode_lost(modes, both, "simulator"))
  # a base mode the rounds explored (runs within a step of its maximum) is
  # the data's to drop: only the mode around which no run went is warned of
  big <- modes$share >= mode_lost_share
  at <- vapply(modes$at, function(a) a$th1, numeric(1))
  explored <- mode_explored(modes, as.matrix(lib_theta(one$library)))
  expect_equal(explored[big][order(at[big])], c(FALSE, TRUE))
  # the emulator route's warning names the simulator
  expect_warning(warn_mode_lost(modes, one, "emulator"), "simulator =")
})

test_that("a base posterior on few runs gets a search round seeded at both modes", {
  fit <- folded_fit()
  state <- refine_state(fit)
  search <- mode_search_proposal(state)
  expect_true(is_search_proposal(search))
  centres <- vapply(search$components, function(cmp) cmp$centre[1], numeric(1))
  expect_true(any(abs(centres - 1 / 3) < 1e-9) && any(abs(centres - 2 / 3) < 1e-9))
  expect_equal(search$defensive, mode_search_uniform)
  # its density is a proposal's, so the prior weights stay uniform
  expect_gt(proposal_density(search, data.frame(th1 = 1 / 3, th2 = 0.5)),
            proposal_density(search, data.frame(th1 = 0.02, th2 = 0.02)))
  # once the rounds have begun there is none
  refined <- with_round(fit, rbind(c(0.6, 0.2), c(0.9, 0.6)))
  expect_null(mode_search_proposal(refine_state(refined)))
})

test_that("a search that seeds one maximum draws around it from a flat box, and boxes follow", {
  # the one-parameter toy: its 7-run base posterior has one maximum. With a
  # t component there and proposals after the search, the prior weights
  # inside the last box spread by a factor of 100 (test-library-refined.R)
  # and the toy took more than 600 runs where boxes resolve it
  toy <- refine_toy()
  search <- mode_search_proposal(refine_state(toy$fit))
  expect_length(search$components, 1L)
  expect_true(search_boxes(search))
  expect_false(proposals_follow(search))
  box <- from_unit(search_box(search$components[[1]]), search$range, search$varies)[, 1]
  inner <- data.frame(k = box[1] + c(0.1, 0.5, 0.9) * (box[2] - box[1]))
  outer <- data.frame(k = c(box[1] - 0.01, box[2] + 0.01))
  dens <- proposal_density(search, inner)
  expect_equal(dens, rep(dens[1], 3))
  expect_equal(proposal_density(search, outer), rep(mode_search_uniform / 3, 2))
  # the density integrates to 1 over the range [1, 4]
  grid <- data.frame(k = seq(1, 4, length.out = 30001))
  expect_equal(mean(proposal_density(search, grid)) * 3, 1, tolerance = 1e-3)
  set.seed(1)
  draws <- draw_proposal(2000, search, "k")$k
  expect_equal(mean(draws >= box[1] & draws <= box[2]),
               mode_search_uniform * (box[2] - box[1]) / 3 + 1 - mode_search_uniform,
               tolerance = 0.05)
  refined <- refine(toy$fit, refine_sim, max_runs = 400, seed = 1)
  rounds <- lib_rounds(refined$library)
  expect_true(is_search_proposal(rounds[[1]]$proposal))
  expect_true(all(vapply(rounds[-1], function(r) is.null(r$proposal), logical(1))))
  expect_false(has_proposal_rounds(refined$library))
  expect_identical(refined$refinement$reason, "resolved")
  # a search seeding both modes of the folded system keeps t components,
  # and proposals follow it
  both <- mode_search_proposal(refine_state(folded_fit()))
  expect_false(search_boxes(both))
  expect_true(proposals_follow(both))
})

test_that("a plateau of equal weights is one local maximum", {
  u <- as.matrix(expand.grid(seq(0, 1, 0.25), seq(0, 1, 0.25)))
  # flat along the second axis at u1 = 0.5 (a model that ignores it there)
  lw <- ifelse(u[, 1] == 0.5, 0, -1 - u[, 2])
  lw[u[, 1] == 0 & u[, 2] == 0] <- -0.5
  expect_equal(local_maxima(u, lw, 3L, -10, 8L), c(which(lw == 0)[1], which(lw == -0.5)))
})

test_that("refine() from a 64-run grid keeps both modes of the aliased oscillator", {
  # bench/coarse-start-modes.R's osc-64, trial 1: the old code's rounds
  # zoomed in on the true mode and lost the alias at w + 4, "resolved",
  # without a warning
  tt <- (1:80) * pi / 2
  sim <- function(theta) {
    th <- as.matrix(theta)
    t(vapply(seq_len(nrow(th)), function(i) exp(-th[i, 2] * tt / 20) * sin(th[i, 1] * tt),
             numeric(length(tt))))
  }
  grid <- expand.grid(w = seq(1, 7, length.out = 8), c = seq(0.5, 2, length.out = 8))
  lib <- sim_library(grid, sim(grid))
  set.seed(101)
  truth <- c(w = runif(1, 1.5, 2.5), c = runif(1, 0.8, 1.7))
  y <- sim(as.data.frame(t(truth)))[1, ] + rnorm(80, sd = 0.03)
  fit <- suppressWarnings(calibrate(lib, field_data(matrix(y, 1), t = lib$t), n_iter = 1000,
                                    burn_in = 200, seed = 1))
  lost <- FALSE
  r <- withCallingHandlers(suppressMessages(refine(fit, sim, seed = 1)),
                           griddy_warning_mode_lost = function(w) {
                             lost <<- TRUE
                             invokeRestart("muffleWarning")
                           })
  w <- lib_theta(r$library)$w[r$draws$run]
  expect_false(lost)
  expect_gt(mean(abs(w - truth[["w"]]) < 1), 0.2)
  expect_gt(mean(abs(w - truth[["w"]] - 4) < 1), 0.2)
})
