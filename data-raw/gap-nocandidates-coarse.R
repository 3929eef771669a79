# diagnose_gap(fit) without candidates on coarse libraries with the truth
# between runs and no effect: the libraries as they are (max_runs = 0) against
# matched resolution (the default). Run from the package root:
#   Rscript data-raw/gap-nocandidates-coarse.R
# Results: inst/extdata/gap_nocandidates_coarse.csv. Uses osc_loc() of
# data-raw/gap-nocandidates.R (sourced up to its trials).
pkgload::load_all(".", quiet = TRUE)
src <- readLines("data-raw/gap-nocandidates.R")
# without its load_all(): a second load_all() in one session fails (pkgload 1.3.2, rlang 1.1.5)
src <- src[!grepl("^pkgload::load_all", src)]
eval(parse(text = src[seq_len(grep("^# truth on the library", src) - 1L)]))
trials <- expand.grid(seed = 1:3, n_grid = c(11, 7))
rows <- lapply(seq_len(nrow(trials)), function(i) {
  tr <- trials[i, ]
  s <- osc_loc(n_grid = tr$n_grid, gap = 0, seed = tr$seed, truth = c(w = 6.35, c = 0.84))
  fit <- suppressWarnings(calibrate(s$library, s$field, n_iter = 300, burn_in = 100, seed = 1))
  as_is <- diagnose_gap(fit, max_runs = 0)
  matched <- diagnose_gap(fit, seed = 1)
  out <- cbind(tr, answer_as_is = as_is$verdict$answer,
               log_bf_as_is = as_is$evidence$log_bayes_factor,
               answer_matched = matched$verdict$answer,
               log_bf_matched = matched$evidence$log_bayes_factor,
               runs_matched = matched$settings$runs)
  print(out)
  out
})
utils::write.csv(do.call(rbind, rows), "inst/extdata/gap_nocandidates_coarse.csv",
                 row.names = FALSE)
