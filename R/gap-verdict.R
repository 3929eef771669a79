# The verdict of a gap diagnosis: the rules that decide diagnose_gap()'s
# answer, with candidates (gap_verdict()) and without (discrepancy_verdict()).
# print() and summary() only say it (gap_diagnosis-methods.R).

# The verdict from the models' table `which_tab` (most probable first) and
# the leave-block-out checks `where`: the most probable model that is not
# confounded with theta, unless that is "none" while blocks are flagged, when
# a gap is there even if no model beats the base model in evidence (a gap too
# local or too rough): then "other", for reason "blocks".
gap_verdict <- function(which_tab, separation, base, where) {
  ok <- !which_tab$confounded
  answer <- which_tab$effect[ok][1]
  prob <- which_tab$prob[ok][1]
  n_flagged <- sum(where$blocks$flagged)
  reason <- if (answer == "none" && n_flagged > 0L) "blocks" else "evidence"
  if (reason == "blocks") {
    answer <- "other"
    prob <- which_tab$prob[which_tab$effect == "other"]
  }
  conf <- which_tab$effect[which_tab$confounded]
  advice <- gap_advice(which_tab, separation, lib_x(base))
  list(answer = answer, prob = prob, reason = reason, confounded = conf,
       advice = unname(advice), n_flagged = n_flagged,
       prob_none = which_tab$prob[which_tab$effect == "none"])
}

# The posterior log odds of "other" against "none" above which the answer is
# "other": the top of the band that evidence_words() calls inconclusive.
gap_detect_log_odds <- 1

# Whether the models' probabilities `prob` (named "none" and "other") show a
# gap: evidence at least positive, the posterior log odds of "other" beyond
# Kass and Raftery's inconclusive band.
gap_found <- function(prob) log(prob[["other"]]) - log(prob[["none"]]) > gap_detect_log_odds

# The verdict without candidates (gap_without_candidates()): gap_verdict()'s,
# marked mode "discrepancy", then, unless the evidence finds a gap (`found`),
# "other" only when the base model's own block checks flag blocks
# (`where$kind` "check", reason "blocks"), else "none" (reason
# "inconclusive" when "other" was the more probable).
discrepancy_verdict <- function(which_tab, base, where, prob, found) {
  verdict <- c(gap_verdict(which_tab, NULL, base, where), list(mode = "discrepancy"))
  if (!found && identical(where$kind, "check")) {
    verdict[c("answer", "prob", "reason")] <- list("other", prob[["other"]], "blocks")
  } else if (!found && verdict$answer == "other") {
    verdict[c("answer", "prob", "reason")] <- list("none", prob[["none"]], "inconclusive")
  }
  verdict
}
