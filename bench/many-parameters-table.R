# The summary table of bench/README.md's "Many parameters" section, from
# the CSVs bench/many-parameters.R writes (one row per trial and parameter).
# Run: Rscript bench/many-parameters-table.R  (prints markdown; writes
# inst/extdata/many_parameters_trials.csv, one row per trial, for the vignette)
library(data.table)
files <- Sys.glob("bench/results/many-parameters-*.csv")
files <- files[grepl("many-parameters-(smooth|sharp|bimodal)-[0-9]+\\.csv$", files)]
d <- rbindlist(lapply(files, fread), fill = TRUE)
d[, p := as.integer(sub(".*-", "", system))]
d[, kind := sub("-.*", "", system)]
setorder(d, kind, p, trial)
range_text <- function(x, digits = 2) {
  r <- range(x)
  if (r[1] == r[2]) format(r[1], digits = digits) else
    paste0(format(r[1], digits = digits), "-", format(r[2], digits = digits))
}
tab <- d[, {
  per_trial <- unique(.SD[, .(trial, runs_added, seconds, simulator_seconds, reason,
                              effective_runs, mirror_mass)])
  .(trials = nrow(per_trial), pairs = .N,
    plain = sprintf("%.0f%%", 100 * mean(plain_covered)),
    refine = sprintf("%.0f%%", 100 * mean(covered)),
    reference = sprintf("%.0f%%", 100 * mean(ref_covered)),
    width = sprintf("%.2f", median(width_ratio)),
    missed_unwarned_ref_covered = sum(!covered & !warned & ref_covered),
    resolved = sum(per_trial$reason == "resolved"),
    runs = range_text(per_trial$runs_added, 5),
    seconds = sprintf("%.1f", median(per_trial$seconds)),
    ms_outside = range_text(1000 * (per_trial$seconds - per_trial$simulator_seconds) /
                              per_trial$runs_added, 2),
    mirror = if (all(is.na(per_trial$mirror_mass))) "" else range_text(per_trial$mirror_mass, 2),
    load = range_text(as.numeric(sub("load ([0-9.]+).*", "\\1", machine)), 2))
}, by = .(system, kind, p)]
cat("| system | trials (pairs) | plain fit covers | refine covers | reference covers |",
    "median width / reference | misses the reference covers, unwarned | resolved trials |",
    "runs added | median time (s) | outside the simulator per run (ms) |",
    "mirror-mode mass | load |\n")
cat("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n")
for (i in seq_len(nrow(tab))) with(tab[i], cat(
  "|", system, "|", paste0(trials, " (", pairs, ")"), "|", plain, "|", refine, "|", reference,
  "|", width, "|", missed_unwarned_ref_covered, "|", resolved, "|", runs, "|", seconds, "|",
  ms_outside, "|", mirror, "|", load, "|\n"))
all <- d[, .(pairs = .N, refine = mean(covered), reference = mean(ref_covered),
             width_lo = min(width_ratio), width_hi = max(width_ratio),
             width_med = median(width_ratio))]
cat(sprintf("\nAll %d pairs: refine covers %.1f%%, the reference %.1f%%; width / reference %.2f-%.2f (median %.2f).\n",
            all$pairs, 100 * all$refine, 100 * all$reference, all$width_lo, all$width_hi,
            all$width_med))

# Per trial, for vignette("between-the-runs"): what each refinement did.
trials <- d[, .(p = p[1], kind = kind[1], runs_added = runs_added[1], reason = reason[1],
                mirror_mass = mirror_mass[1], coverage = mean(covered),
                ref_coverage = mean(ref_covered), width_ratio = median(width_ratio),
                warned = warned[1], seconds = seconds[1]), by = .(system, trial)]
fwrite(trials, "inst/extdata/many_parameters_trials.csv")
