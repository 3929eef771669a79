# The verdict of a gap diagnosis: the rules that decide diagnose_gap()'s
# answer, with candidates (gap_verdict()) and without (discrepancy_verdict()).
# print() and summary() only say it (gap-methods.R).

# The verdict from the models' table `which_tab` (most probable first) and
# the leave-block-out checks `where`: the most probable model that is not
# confounded with theta, if its evidence passes gap_shown()'s bar (else
# "none"), unless that is "none" while blocks are flagged, when
# a gap is there even if no model beats the base model in evidence (a gap too
# local or too rough): then "other", for reason "blocks".
gap_verdict <- function(which_tab, separation, base, where) {
  ok <- !which_tab$confounded
  answer <- which_tab$effect[ok][1]
  prob <- which_tab$prob[ok][1]
  prob_none <- which_tab$prob[which_tab$effect == "none"]
  n_flagged <- sum(where$blocks$flagged)
  reason <- "evidence"
  # a model, candidate or "other", is named only past the bar of gap_shown():
  # log odds against the base model beyond gap_detect_log_odds (below it,
  # "none", for reason "inconclusive", with the model that fell short)
  short <- NULL
  if (answer != "none" && !gap_shown(log(prob) - log(prob_none))) {
    short <- list(effect = answer, prob = prob)
    answer <- "none"
    prob <- prob_none
    reason <- "inconclusive"
  }
  if (answer == "none" && n_flagged > 0L) reason <- "blocks"
  if (reason == "blocks") {
    answer <- "other"
    prob <- which_tab$prob[which_tab$effect == "other"]
  }
  conf <- which_tab$effect[which_tab$confounded]
  advice <- gap_advice(which_tab, separation, lib_x(base))
  list(answer = answer, prob = prob, reason = reason, confounded = conf,
       advice = unname(advice), n_flagged = n_flagged, prob_none = prob_none,
       short = short)
}

# ---- the one rule for "is there a gap" ------------------------------------------
#
# Every place that says whether the data show a gap uses gap_shown():
# calibrate()'s and refine()'s warning (the gap screen of a fit without a
# discrepancy, warn_gap_screen(); a fit's own discrepancy, warn_gap()),
# print() and summary() of a fit, and diagnose_gap() with and without
# candidates. A gap is shown when
# * the evidence for it is at least positive: log odds (under equal prior
#   odds, the log Bayes factor) of a gap against none beyond
#   gap_detect_log_odds, the top of the band that Kass and Raftery's scale
#   (evidence_words()) calls inconclusive; or
# * the base model's own leave-block-out checks (gap_where(), one x setting
#   times one window of t, Benjamini-Hochberg at gap_block_fdr) flag a
#   block: a gap too local or too rough for a smooth discrepancy to win in
#   evidence (a second peak at one setting).
# The bar is the one diagnose_gap() was validated with (no false alarm in
# 122 trials without a gap on three unseen systems; bench/gap-signal.R
# measures it on calibrate()'s side). It is not tuned to any study's trials.

# The posterior log odds of a gap against none above which the evidence shows
# one.
gap_detect_log_odds <- 1

# The false discovery rate of the block checks, diagnose_gap()'s default `fdr`
# (test-gap-verdict.R holds them equal). On data without a gap, Benjamini-
# Hochberg at level q flags some block with probability at most about q (all
# nulls true, it is Simes' test of them all, which holds its level under
# positive dependence, as overlapping blocks have), and the evidence rule can fire
# besides: half the 5% false-alarm budget goes to the blocks. At 0.05 a
# tiling of 24 blocks alone gave 5 false alarms in 90 trials (bench/gap-
# signal.R's system). The default windows scan t (scan_windows(), 207 blocks
# there): the level is the same, and the scan's multiplicity is paid inside
# it (false alarms 1 of 90 there and 1 of 30 on bench/gap-signal-cooling.R's
# system, which the rule was not designed on).
gap_block_fdr <- 0.025

# Whether log odds `log_odds` of a gap against none (NA: not weighed) and
# `n_flagged` blocks flagged by the base model's checks show a gap.
gap_shown <- function(log_odds, n_flagged = 0L) {
  isTRUE(log_odds > gap_detect_log_odds) || isTRUE(n_flagged > 0L)
}

# Whether the models' probabilities `prob` (named "none" and "other") show a
# gap on the evidence alone.
gap_found <- function(prob) gap_shown(log(prob[["other"]]) - log(prob[["none"]]))

# Whether data of `n_obs` measurements can weigh a gap at all. One
# measurement (one observed output, no replicates) is fitted as well by noise
# as by noise plus a gap, whatever its value: the evidence cannot move and a
# block check has nothing left to predict the block from. The screen, the
# summary of a fit and diagnose_gap() then say so (gap_unweighable_sentence)
# rather than "no gap".
gap_weighable <- function(n_obs) isTRUE(n_obs > 1)

gap_unweighable_sentence <- paste0(
  "cannot tell whether there is a gap: a single measurement is fitted as well by noise as by ",
  "a gap, so no evidence for or against one is possible (replicate it, or measure more ",
  "settings or outputs)")

# What every gap warning says theta then is (a fit without a discrepancy has
# bent theta to absorb the gap; one with a discrepancy estimates the value
# its discrepancy's prior defines).
gap_theta_sentence <- "theta is then a best-fitting value, not the physical one"

# The verdict without candidates (gap_without_candidates()): gap_verdict()'s,
# marked mode "discrepancy", then, unless the evidence finds a gap (`found`),
# "other" only when the base model's own block checks flag blocks
# (`where$kind` "check", reason "blocks"), else "none" (reason
# "inconclusive" when "other" was the more probable); on data that cannot
# weigh a gap (`weighable` FALSE, gap_weighable()), "none" for reason
# "unweighable", at no probability.
discrepancy_verdict <- function(which_tab, base, where, prob, found, weighable = TRUE) {
  verdict <- c(gap_verdict(which_tab, NULL, base, where), list(mode = "discrepancy"))
  if (!weighable) {
    # no evidence is possible (gap_weighable()): neither "none" at its
    # probability nor "other"
    verdict[c("answer", "prob", "reason")] <- list("none", NA_real_, "unweighable")
  } else if (!found && identical(where$kind, "check")) {
    verdict[c("answer", "prob", "reason")] <- list("other", prob[["other"]], "blocks")
  } else if (!found && verdict$answer == "other") {
    verdict[c("answer", "prob", "reason")] <- list("none", prob[["none"]], "inconclusive")
  }
  verdict
}
