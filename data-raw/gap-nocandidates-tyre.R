# diagnose_gap(fit) without candidates on the tyre system of
# data-raw/gap-validation.R (Fiala library, PAC2002-style data, AR(1) noise
# with lag-one correlation 0.5, three cleat heights x 100 samples): nulls on
# and off the library grid, withheld effects, and its planted local pulse.
# Run from the package root:  Rscript data-raw/gap-nocandidates-tyre.R
# (GAP_TRIALS_TYRE trials per scenario, default 3). Results:
# inst/extdata/gap_nocandidates_tyre.csv.
src <- readLines("data-raw/gap-validation.R")
# the validation script's set-up and trial functions, without its scenarios
eval(parse(text = src[seq_len(grep("^all_tyre <- ", src) - 1L)]))
n_trials <- as.integer(Sys.getenv("GAP_TRIALS_TYRE", "3"))
design <- tyre_design(tyre_conditions(), effects = character(0))
scenarios <- list(
  list(id = "T0 null", truth = "none"),
  list(id = "T0b null, theta off the library grid", truth = "none", off_grid = TRUE),
  list(id = "T1 quadratic stiffness", truth = "quadratic"),
  list(id = "T2 rigid-disc contact", truth = "disc"),
  list(id = "T7 planted local pulse (second height, 55 ms)", truth = "none", bump = 1500)
)
rows <- list()
for (sc in scenarios) {
  for (i in seq_len(n_trials)) {
    start <- proc.time()[["elapsed"]]
    res <- tyre_trial(design, sc$id, sc$truth, character(0), seed = 1000 + i,
                      off_grid = isTRUE(sc$off_grid), bump = if (is.null(sc$bump)) 0 else sc$bump)
    row <- res$row[, .(scenario, seed, truth, answer, prob_other, n_blocks, n_flagged,
                       bump_hit, false_flags)]
    row$log_bf <- res$gap$evidence$log_bayes_factor
    row$seconds <- proc.time()[["elapsed"]] - start
    print(row)
    rows[[length(rows) + 1L]] <- row
  }
}
fwrite(rbindlist(rows), "inst/extdata/gap_nocandidates_tyre.csv")
