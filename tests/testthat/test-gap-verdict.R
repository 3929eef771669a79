# The rules that decide diagnose_gap()'s answer (gap-verdict.R), on tables
# made by hand.

verdict_table <- function(effect, prob, confounded = rep(FALSE, length(effect))) {
  data.frame(effect = effect, prob = prob, log_evidence = log(prob), confounded = confounded,
             separable = NA_real_, detectable = NA_real_, absorbed_by = "a",
             stringsAsFactors = FALSE)
}

verdict_lib <- function() {
  sim_library(data.frame(a = 1:3), matrix(1:12, 3, 4), x = data.frame(u = 1:2),
              t = 1:2)
}

blocks_flagged <- function(flagged) list(blocks = data.frame(flagged = flagged))

test_that("the verdict is the most probable model not confounded with theta", {
  tab <- verdict_table(c("scale", "quadratic", "none"), c(0.6, 0.3, 0.1),
                       confounded = c(TRUE, FALSE, FALSE))
  v <- gap_verdict(tab, NULL, verdict_lib(), blocks_flagged(c(FALSE, FALSE)))
  expect_identical(v[c("answer", "prob", "reason", "confounded", "n_flagged", "prob_none")],
                   list(answer = "quadratic", prob = 0.3, reason = "evidence",
                        confounded = "scale", n_flagged = 0L, prob_none = 0.1))
  expect_match(paste(v$advice, collapse = " "), "'scale' is confounded with a")
})

test_that("'none' with flagged blocks is 'other', for reason 'blocks'", {
  tab <- verdict_table(c("none", "other"), c(0.9, 0.1))
  v <- gap_verdict(tab, NULL, verdict_lib(), blocks_flagged(c(TRUE, FALSE, TRUE)))
  expect_identical(v[c("answer", "prob", "reason", "n_flagged")],
                   list(answer = "other", prob = 0.1, reason = "blocks", n_flagged = 2L))
  # a model beating "none" keeps its answer whatever the blocks say
  tab <- verdict_table(c("quadratic", "none"), c(0.9, 0.1))
  v <- gap_verdict(tab, NULL, verdict_lib(), blocks_flagged(TRUE))
  expect_identical(v[c("answer", "reason")], list(answer = "quadratic", reason = "evidence"))
})

test_that("without candidates a gap needs log odds beyond 1, or the base model's flagged blocks", {
  expect_true(gap_found(c(none = 0.2, other = 0.8)))            # log odds 1.39
  expect_false(gap_found(c(none = 0.3, other = 0.7)))           # log odds 0.85
  lib <- verdict_lib()
  # inconclusive: "other" more probable, not by enough
  prob <- c(none = 0.3, other = 0.7)
  tab <- verdict_table(c("other", "none"), c(0.7, 0.3))
  where <- c(blocks_flagged(FALSE), list(kind = "discrepancy"))
  v <- discrepancy_verdict(tab, lib, where, prob, gap_found(prob))
  expect_identical(v[c("answer", "prob", "reason", "mode")],
                   list(answer = "none", prob = 0.3, reason = "inconclusive",
                        mode = "discrepancy"))
  # the base model's own check flags blocks: "other", for reason "blocks"
  where <- c(blocks_flagged(TRUE), list(kind = "check"))
  v <- discrepancy_verdict(tab, lib, where, prob, gap_found(prob))
  expect_identical(v[c("answer", "prob", "reason")],
                   list(answer = "other", prob = 0.7, reason = "blocks"))
  # found: the evidence's answer
  prob <- c(none = 0.1, other = 0.9)
  tab <- verdict_table(c("other", "none"), c(0.9, 0.1))
  where <- c(blocks_flagged(TRUE), list(kind = "discrepancy"))
  v <- discrepancy_verdict(tab, lib, where, prob, gap_found(prob))
  expect_identical(v[c("answer", "prob", "reason")],
                   list(answer = "other", prob = 0.9, reason = "evidence"))
  # no gap: "none" on the evidence
  prob <- c(none = 0.8, other = 0.2)
  tab <- verdict_table(c("none", "other"), c(0.8, 0.2))
  v <- discrepancy_verdict(tab, lib, c(blocks_flagged(FALSE), list(kind = "discrepancy")),
                           prob, gap_found(prob))
  expect_identical(v[c("answer", "prob", "reason")],
                   list(answer = "none", prob = 0.8, reason = "evidence"))
})

test_that("one rule shows a gap: log odds beyond 1, or a block flagged", {
  expect_false(gap_shown(0.9))
  expect_true(gap_shown(1.1))
  expect_true(gap_shown(-3, n_flagged = 1L))   # a local gap the evidence misses
  expect_false(gap_shown(-3, n_flagged = 0L))
  expect_false(gap_shown(NA_real_))
  # the screen's warning and diagnose_gap() without candidates share it
  expect_identical(gap_found(c(none = 0.2, other = 0.8)), gap_shown(log(0.8 / 0.2)))
})

test_that("a candidate is named only past the bar 'other' needs", {
  # issue 33: an effect was named at P = 0.63 on data without it
  tab <- verdict_table(c("quadratic", "none", "other"), c(0.63, 0.3, 0.07))
  v <- gap_verdict(tab, NULL, verdict_lib(), blocks_flagged(c(FALSE, FALSE)))
  expect_identical(v[c("answer", "prob", "reason", "short")],
                   list(answer = "none", prob = 0.3, reason = "inconclusive",
                        short = list(effect = "quadratic", prob = 0.63)))
  # with a flagged block the gap is still there, unnamed
  v <- gap_verdict(tab, NULL, verdict_lib(), blocks_flagged(c(TRUE, FALSE)))
  expect_identical(v[c("answer", "reason")], list(answer = "other", reason = "blocks"))
  # past the bar (log odds 1.34), named
  tab <- verdict_table(c("quadratic", "none", "other"), c(0.76, 0.2, 0.04))
  v <- gap_verdict(tab, NULL, verdict_lib(), blocks_flagged(FALSE))
  expect_identical(v[c("answer", "reason")], list(answer = "quadratic", reason = "evidence"))
  expect_match(verdict_explanation(list(verdict = gap_verdict(
    verdict_table(c("quadratic", "none", "other"), c(0.63, 0.3, 0.07)), NULL, verdict_lib(),
    blocks_flagged(FALSE)), which = tab[0, ], shrinkage = empty_shrinkage())),
    "the evidence for 'quadratic' is inconclusive (P(quadratic) = 63.0%", fixed = TRUE)
})

test_that("calibrate()'s screen and diagnose_gap() flag blocks at the same level", {
  expect_identical(formals(diagnose_gap)$fdr, gap_block_fdr)
})

test_that("a single measurement cannot weigh a gap: the verdict says so, at no probability", {
  # issue 33: diagnose_gap() on a library of one output said "no gap, P = 50%"
  expect_false(gap_weighable(1L))
  expect_true(gap_weighable(2L))
  prob <- c(none = 0.5, other = 0.5)
  tab <- verdict_table(c("none", "other"), c(0.5, 0.5))
  v <- discrepancy_verdict(tab, verdict_lib(), c(blocks_flagged(FALSE), list(kind = "discrepancy")),
                           prob, FALSE, weighable = FALSE)
  expect_identical(v[c("answer", "prob", "reason")],
                   list(answer = "none", prob = NA_real_, reason = "unweighable"))
  expect_match(verdict_label(v), "^cannot tell")
  expect_match(verdict_explanation(list(verdict = v, which = tab[0, ],
                                        shrinkage = empty_shrinkage())),
               "cannot tell whether there is a gap", fixed = TRUE)
})
