# diagnose_gap(fit) without candidates on gap-long-field.R's system (1,296
# runs, 480 field points, a 10-point rho_t grid), before and after in ONE
# process: griddy is loaded from an installed library (the before side), then
# the R files that differ between the two commits are sourced into its
# namespace (the after side). Valid only when src/ is the same at both
# commits (the script checks). Each side times plain calibrate() and
# diagnose_gap(fit, seed = 1) `GAP_AB_REPS` times, alternating, and the
# results of both sides are compared (verdict, evidence, every table).
#
# Run from the package root of the after commit:
#   GAP_AB_BEFORE=/tmp/lib-now GAP_AB_FROM=abb7bf2 Rscript bench/gap-long-field-ab.R
# GAP_AB_OUT: the results stem (default bench/results/gap-long-field-ab).
before_lib <- Sys.getenv("GAP_AB_BEFORE", "/tmp/lib-now")
from <- Sys.getenv("GAP_AB_FROM", "abb7bf2")
reps <- as.integer(Sys.getenv("GAP_AB_REPS", "3"))
ab_stem <- Sys.getenv("GAP_AB_OUT", "bench/results/gap-long-field-ab")
git <- function(...) system2("git", c(...), stdout = TRUE)
if (length(git("diff", "--name-only", from, "HEAD", "--", "src"))) {
  stop("src/ differs between ", from, " and HEAD: install both sides instead")
}
changed <- grep("^R/.*[.]R$", git("diff", "--name-only", from, "HEAD", "--", "R"), value = TRUE)
library(griddy, lib.loc = before_lib)
Sys.setenv(GAP_LONG_PARTS = "plain", GAP_LONG_OUT = tempfile())
source("bench/gap-long-field.R")   # the system, `timed()`, and one plain fit
fit <- res$plain$value

# the after side: the changed files' definitions replace the installed ones
overlay <- function(files) {
  ns <- asNamespace("griddy")
  for (f in files) {
    env <- new.env(parent = ns)
    sys.source(f, envir = env)
    # the functions keep `env` as their environment: a name new in the file
    # (the namespace is locked) stays there, where the file's functions find it
    for (nm in ls(env, all.names = TRUE)) {
      if (!exists(nm, ns, inherits = FALSE)) next
      unlockBinding(nm, ns)
      assign(nm, get(nm, env), envir = ns)
      lockBinding(nm, ns)
    }
  }
}
cpu_of <- function(expr) {
  t0 <- proc.time()
  value <- force(expr)
  used <- proc.time() - t0
  list(value = value, cpu = used[["user.self"]] + used[["sys.self"]], s = used[["elapsed"]])
}
side <- function(label) {
  rows <- list()
  for (r in seq_len(reps)) {
    plain <- cpu_of(do.call(calibrate, fit_args))
    gap <- cpu_of(diagnose_gap(fit, progress = FALSE, seed = 1))
    rows[[r]] <- data.frame(side = label, rep = r, plain_cpu = plain$cpu, gap_cpu = gap$cpu,
                            plain_s = plain$s, gap_s = gap$s, ratio_cpu = gap$cpu / plain$cpu)
  }
  list(tab = do.call(rbind, rows), gap = gap$value)
}
before <- side("before")
overlay(changed)
after <- side("after")
tab <- rbind(before$tab, after$tab)
tab[, 3:7] <- round(tab[, 3:7], 3)
print(tab)
same <- all.equal(unclass(before$gap), unclass(after$gap), tolerance = 0)
cat("changed files:", changed, "\n")
cat("verdict:", before$gap$verdict$answer, "->", after$gap$verdict$answer,
    "; log Bayes factor:", format(before$gap$evidence$log_bayes_factor, digits = 15), "->",
    format(after$gap$evidence$log_bayes_factor, digits = 15), "\n")
cat("diagnosis identical (all.equal, tolerance 0):", isTRUE(same), "\n")
if (!isTRUE(same)) print(same)
utils::write.csv(tab, paste0(ab_stem, ".csv"), row.names = FALSE)
writeLines(c(paste("before: griddy installed at", before_lib, "(", from, ")"),
             paste("after: HEAD", git("rev-parse", "--short", "HEAD"), "with",
                   paste(changed, collapse = ", ")),
             paste("diagnosis identical:", isTRUE(same)),
             paste("log Bayes factor:", format(after$gap$evidence$log_bayes_factor,
                                               digits = 15)),
             machine_note()), paste0(ab_stem, ".txt"))
