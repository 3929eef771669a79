# What print() or the summary's print() shows, as one line of single spaces.
printed <- function(x) gsub("\\s+", " ", paste(capture.output(print(x)), collapse = " "))

test_that("print reads as a verdict with the numbers", {
  toy <- toy_gap(0.2)
  gap <- diagnose_gap(toy$fit, list(scale = toy$scale, quadratic = toy$quad))
  out <- printed(gap)
  expect_match(out, "Verdict: best explained by 'quadratic' \\(P [=>]")
  expect_match(out, "held-out RMSE [0-9.]+ -> [0-9.]+ \\([0-9.]+% shrinkage\\)")
  expect_match(out, "scale < 0.1% -?[0-9.]+% confounded with a")
  expect_match(out, "To tell a confounded candidate from a shift of theta, measure outside")
  null <- diagnose_gap(toy_gap(0)$fit, list(quadratic = toy$quad))
  expect_match(printed(null), "Verdict: no gap \\(P = [0-9.]+%\\)")
  other <- diagnose_gap(toy_gap(0.3)$fit, list(scale = toy$scale))
  expect_match(printed(other), "no candidate explains")
})

# Two effects a shift of `a` imitates (a rescaling up and one down) and one it
# does not: a 3-candidate diagnosis with two confounded.
three_candidate_gap <- function() {
  toy <- toy_gap(0.2)
  g <- expand.grid(a = lib_theta(toy$lib)$a, s = c(0, 0.1, 0.2))
  shrink_a <- sim_library(g, t(mapply(function(a, s) toy$sim(a * (1 - s), 0), g$a, g$s)),
                          x = toy$x, t = toy$t)
  diagnose_gap(toy$fit, list(scale = toy$scale, shrink_a = shrink_a, quadratic = toy$quad))
}

sentences <- function(lines) {
  text <- gsub("\\s+", " ", paste(trimws(lines), collapse = " "))
  trimws(strsplit(text, "(?<=[.])\\s+(?=[A-Z'])", perl = TRUE)[[1]])
}

test_that("print is short: one line per model, the advice once, within the width", {
  # print repeated the design advice for every confounded candidate, in
  # lines wider than the console
  withr::local_options(width = 80)
  gap <- three_candidate_gap()
  expect_identical(sum(gap$which$confounded), 2L)
  lines <- capture.output(print(gap))
  expect_lte(length(lines), 13L)
  expect_true(all(nchar(lines) <= 80L))
  expect_false(anyDuplicated(sentences(lines)) > 0L)
  expect_identical(sum(grepl("To tell a confounded candidate", lines)), 1L)
  for (m in gap$which$effect) expect_identical(sum(grepl(paste0("^  ", m, " "), lines)), 1L)
  expect_identical(sum(grepl("confounded with a$", lines)), 2L)
  expect_no_match(paste(lines, collapse = " "), "[0-9]e-[0-9]")
})

test_that("the shipped validation examples print short", {
  ex <- readRDS(system.file("extdata", "gap_validation_examples.rds", package = "griddy"))
  withr::local_options(width = 80)
  # five candidates, four confounded with k: 17 lines of which 12 repeated advice
  lines <- capture.output(print(ex$examples[["T0 null"]]))
  expect_lte(length(lines), 14L)
  expect_false(anyDuplicated(sentences(lines)) > 0L)
  expect_identical(sum(grepl("To tell a confounded candidate", lines)), 1L)
})

test_that("summary() keeps what print() leaves out", {
  gap <- three_candidate_gap()
  s <- summary(gap)
  expect_s3_class(s, "gap_diagnosis_summary")
  expect_identical(s$models$effect, gap$which$effect)
  expect_identical(s$models$prob, gap$which$prob)
  expect_true(all(c(names(gap$which), setdiff(names(gap$shrinkage), "effect")) %in%
                    names(s$models)))
  cand <- match(gap$shrinkage$effect, s$models$effect)
  expect_identical(s$models$shrink[cand], gap$shrinkage$shrink)
  expect_identical(s$advice, gap$verdict$advice)
  out <- gsub("\\s+", " ", paste(capture.output(res <- print(s)), collapse = " "))
  expect_identical(res, s)
  expect_match(out, "'scale' and 'shrink_a' are confounded with a: ")
  expect_match(out, "score [0-9.]+")
  expect_match(out, "Adding it cuts the RMSE of held-out settings")
  expect_match(out, "separable")
  expect_match(out, "cover90_after")
})

test_that("probabilities print as readable percentages", {
  expect_identical(format_prob(c(1.1e-8, 0.42749, 0.9999, 0.001)),
                   c("< 0.1%", "42.7%", "> 99.9%", "0.1%"))
  expect_identical(prob_phrase(c(1.1e-8, 0.5)), c("P < 0.1%", "P = 50.0%"))
  expect_identical(prob_phrase(0.99999, "P(other)"), "P(other) > 99.9%")
  expect_identical(format_shrink(c(-0.0004, 0.254)), c("0.0%", "25.4%"))
})

test_that("plot draws a map of the gap with flagged blocks outlined", {
  toy <- toy_gap(0, bump = 0.3)
  gap <- diagnose_gap(toy$fit, list(quadratic = toy$quad), windows = 6)
  p <- plot(gap)
  expect_s3_class(p, "ggplot")
  expect_true(any(vapply(p$layers, function(l) inherits(l$geom, "GeomRect"), logical(1))))
  expect_silent(ggplot2::ggplot_build(p))
  # one output per setting: bars
  lib1 <- sim_library(data.frame(a = 1:5), matrix(rnorm(20), 5, 4), x = data.frame(u = 1:4))
  cand <- sim_library(expand.grid(a = 1:5, s = 0:1),
                      rbind(lib1$y, lib1$y + 1), x = data.frame(u = 1:4))
  fit <- suppressWarnings(calibrate(lib1, field_data(lib1$y[3, ] + 0.1, x = data.frame(u = 1:4)),
                                    n_iter = 200, burn_in = 50, seed = 1,
                                    prior = list(shape = 1, rate = 0.01)))
  g1 <- diagnose_gap(fit, list(shift = cand))
  expect_equal(nrow(g1$where), 4)
  expect_s3_class(plot(g1), "ggplot")
})

test_that("a gap the base model's block check flags is 'other' even when evidence says none", {
  toy <- toy_gap(0, bump = 0.3)
  gap <- diagnose_gap(toy$fit, list(quadratic = toy$quad), windows = 6)
  expect_true(any(gap$where$flagged))
  top <- gap$which$effect[!gap$which$confounded][1]
  if (top == "none") {
    expect_identical(gap$verdict$answer, "other")
    expect_identical(gap$verdict$reason, "blocks")
    expect_match(printed(gap), "Verdict: a local gap no candidate explains")
    expect_match(printed(summary(gap)), "the gap is local or rough")
  } else {
    expect_identical(gap$verdict$reason, "evidence")
  }
  expect_false(gap$verdict$answer %in% c("none", "quadratic"))
})

test_that("a flagged block's place drops t with one output per setting", {
  # "worst at load=6, t 1-1": the t part said nothing
  blocks <- data.frame(x = c(1L, 2L), from = c(1, 0.2), to = c(1, 0.6), n = 1L,
                       score = c(3, 1), flagged = c(TRUE, FALSE))
  gap <- list(where = blocks, settings = list(fdr = 0.05), x = data.frame(load = c(2, 6)), t = 1)
  expect_match(where_line(gap), "worst at load=2\\.$")
  gap$t <- c(0.2, 0.6, 1)
  expect_match(where_line(gap), "worst at load=2, t = 1\\.$")
  gap$where$flagged <- c(FALSE, TRUE)
  expect_match(where_line(gap), "worst at load=6, t 0.2-0.6\\.$")
  gap$x <- NULL
  expect_match(where_line(gap), "worst at t 0.2-0.6\\.$")
  gap$t <- 1
  expect_match(where_line(gap), "worst at the single output\\.$")
})

test_that("settings are named by their values however many there are", {
  # beyond 12 settings the map and "where" named them by row ("x 12")
  many <- list(x = data.frame(load = 1.5 * (1:20), speed = rep(c(2, 20), 10)))
  lab <- gap_x_labels(many)
  expect_identical(lab[12], "load=18, speed=20")
  expect_identical(lab[1], "load=1.5, speed=2")
  expect_identical(gap_x_labels(list(x = NULL)), "1")
})

test_that("the verdict label names a gap the blocks flag without a tiny probability", {
  # the plot's title read "answer: other (P = 1.1e-08)"
  expect_identical(verdict_label(list(answer = "other", reason = "blocks", prob = 1.1e-8)),
                   "a local gap no candidate explains")
  expect_identical(verdict_label(list(answer = "quadratic", reason = "evidence", prob = 0.976)),
                   "best explained by 'quadratic' (P = 97.6%)")
  expect_identical(verdict_label(list(answer = "none", reason = "evidence", prob = 2e-4)),
                   "no gap (P < 0.1%)")
})

test_that("the gap map's title fits a vignette-width figure: the verdict on its own line", {
  # "Gap map: 2 of 12 blocks flagged; best explained by ..." ran past the figure
  toy <- toy_gap(0, bump = 0.3)
  gap <- diagnose_gap(toy$fit, list(quadratic = toy$quad), windows = 6)
  title <- plot(gap)$labels$title
  lines <- strsplit(title, "\n", fixed = TRUE)[[1]]
  expect_gte(length(lines), 2L)
  expect_match(lines[1], "^Gap map: [0-9]+ of [0-9]+ blocks flagged$")
  expect_true(all(nchar(lines) <= 60))
  ggplot2::ggsave(tmp <- tempfile(fileext = ".png"), plot(gap), width = 7, height = 3.2, dpi = 50)
  expect_true(file.exists(tmp))
})

test_that("print.gap_diagnosis() and its summary's print are stable", {
  toy <- toy_gap(0.2)
  gap <- diagnose_gap(toy$fit, list(scale = toy$scale, quadratic = toy$quad), seed = 1)
  expect_snapshot(print(gap))
  expect_snapshot(print(summary(gap)))
})

test_that("print() and summary() say when a candidate's held-out shrinkage is not identified", {
  # issue 33: a figure set by the strength grid was printed as a shrinkage
  toy <- toy_gap(0)
  t <- toy$t
  bump_sim <- function(a, s) {
    toy$sim(a, 0) + c(rep(0, 30), s * exp(-((t - 0.5) / 0.1)^2), rep(0, 30))
  }
  g <- expand.grid(a = lib_theta(toy$lib)$a, s = c(0, 0.1, 0.2, 0.3))
  bump <- sim_library(g, t(mapply(bump_sim, g$a, g$s)), x = toy$x, t = t)
  set.seed(1)
  field <- field_data(matrix(bump_sim(1, 0.15) + stats::rnorm(90, sd = 0.05), 3, byrow = TRUE),
                      x = toy$x, t = t)
  fit <- suppressWarnings(calibrate(toy$lib, field, n_iter = 300, burn_in = 100, seed = 1))
  gap <- diagnose_gap(fit, list(bump = bump, quadratic = toy$quad), seed = 1)
  out <- printed(gap)
  expect_match(out, paste0("Verdict: best explained by 'bump' \\(P [=>] [0-9.]+%\\); its held-out ",
                           "shrinkage is not identified by the held-out settings \\(load=2\\)"))
  expect_match(out, "bump > 99.9% not identified")
  expect_no_match(out, "held-out RMSE")
  s <- summary(gap)
  expect_match(paste(s$explanation, collapse = " "),
               paste0("The held-out shrinkage of 'bump' is not identified by the held-out ",
                      "settings: leaving out load=2, the other settings do not show its effect"))
  expect_match(printed(s), "Held-out settings \\(each x setting left out in turn; NA: not identified")
  expect_match(printed(s), "bump [0-9.]+ NA NA")
  # an unidentified candidate that is not the answer is explained in summary()
  null <- diagnose_gap(toy$fit, list(bump = bump, quadratic = toy$quad), seed = 1)
  expect_identical(null$verdict$answer, "none")
  expect_match(paste(summary(null)$explanation, collapse = " "),
               "The held-out shrinkage of 'bump' is not identified", fixed = TRUE)
})

test_that("with replicates the block checks are shown, not flagged, and print says why", {
  toy <- toy_gap(0.1)
  set.seed(3)
  y <- do.call(rbind, lapply(1:3, function(r) {
    matrix(toy$sim(1, 0.1) + stats::rnorm(90, sd = 0.05), 3, byrow = TRUE)
  }))
  field <- field_data(y, x = toy$x[rep(1:3, 3), , drop = FALSE], t = toy$t)
  fit <- suppressWarnings(calibrate(toy$lib, field, n_iter = 200, burn_in = 50, seed = 1))
  gap <- diagnose_gap(fit, list(quadratic = toy$quad), seed = 1)
  expect_match(printed(gap), paste0("Where: no block flagged: with replicated field data the ",
                                    "block checks do not decide, the evidence alone answers; ",
                                    "least p-value [0-9.e-]+ at load="))
  expect_match(printed(summary(gap)), "least p-value [0-9.e-]+ at load=[0-9]+, t [0-9.]+-[0-9.]+;")
})
