# Runs the test suite from the source tree and ends with one line
# "N passed, N failed, N skipped" (expectations); exits 1 on any failure.
# Usage, from the package root: Rscript tools/run-tests.R
results <- testthat::test_local(".", reporter = testthat::ProgressReporter$new(show_praise = FALSE),
                                stop_on_failure = FALSE)
d <- as.data.frame(results)
failed <- sum(d$failed) + sum(d$error)
skipped <- sum(d$skipped)
passed <- sum(d$passed)
cat(sprintf("\n%d passed, %d failed, %d skipped\n", passed, failed, skipped))
if (failed > 0 || passed == 0) quit(status = 1)
