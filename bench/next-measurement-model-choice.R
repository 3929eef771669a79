# Issue 34, item 3: does choosing each measurement by next_measurement(m,
# about = "model") settle a model choice in fewer measurements than a fixed
# schedule? A synthetic rig with 8 settings x (think cleat heights) and one
# output each, independent noise (replicates allowed). Two models over one
# parameter a (200 runs, a in [0.5, 1.5]): "linear" y = a x and "curved"
# y = a x + 0.04 (x - 4.5)^2; once a is calibrated the curvature shows
# mostly at the ends of the range. Data from one model (a = 1.1, noise
# sd 0.3), prior on tau Gamma(2, 0.2) for both streams.
# Schedules: "fixed" cycles x = 1, ..., 8; "chosen" measures where
# next_measurement(about = "model") ranks first. Count: measurements until
# the true model's probability first reaches 0.99 (capped at 150), over 20
# noise seeds per true model.
#
# Usage, from the package root, with griddy installed:
#   Rscript bench/next-measurement-model-choice.R
# Options (environment): GRIDDY_NEW_LIB (a library holding the griddy to
# test). Writes bench/results/next-measurement-model-choice.csv and .md.
source("bench/helpers.R")
if (nzchar(new_griddy_lib())) .libPaths(c(new_griddy_lib(), .libPaths()))
suppressPackageStartupMessages(library(griddy))
xs <- 1:8
a <- seq(0.5, 1.5, length.out = 200)
curve <- function(x) 0.04 * (x - 4.5)^2
libs <- list(linear = sim_library(data.frame(a = a), outer(a, xs), x = data.frame(x = xs)),
             curved = sim_library(data.frame(a = a), outer(a, xs) + rep(curve(xs), each = 200),
                                  x = data.frame(x = xs)))
truth <- function(model, x) 1.1 * x + if (model == "curved") curve(x) else 0
prior <- list(shape = 2, rate = 0.2)
cap <- 150

settle <- function(true_model, schedule, seed) {
  set.seed(seed)
  m <- stream_models(linear = griddy_stream(libs$linear, prior = prior),
                     curved = griddy_stream(libs$curved, prior = prior))
  for (step in seq_len(cap)) {
    x <- if (schedule == "fixed") xs[(step - 1) %% 8 + 1] else
      next_measurement(m, about = "model")$x[1]
    update(m, y = truth(true_model, x) + rnorm(1, sd = 0.3), x = data.frame(x = x),
           t = libs$linear$t)
    if (exp(m$state$log_prob[[true_model]]) >= 0.99) return(step)
  }
  NA_integer_
}

t0 <- proc.time()[["elapsed"]]
rows <- expand.grid(seed = 1:20, schedule = c("fixed", "chosen"),
                    true_model = c("linear", "curved"), stringsAsFactors = FALSE)
rows$measurements <- mapply(settle, rows$true_model, rows$schedule, rows$seed)
summary_table <- do.call(rbind, lapply(split(rows, list(rows$schedule, rows$true_model)),
                                       function(d) {
  data.frame(true_model = d$true_model[1], schedule = d$schedule[1], trials = nrow(d),
             not_settled = sum(is.na(d$measurements)),
             median = stats::median(d$measurements, na.rm = TRUE),
             lower_quartile = unname(stats::quantile(d$measurements, 0.25, na.rm = TRUE)),
             upper_quartile = unname(stats::quantile(d$measurements, 0.75, na.rm = TRUE)))
}))
rownames(summary_table) <- NULL
dir.create("bench/results", showWarnings = FALSE)
write.csv(rows, "bench/results/next-measurement-model-choice.csv", row.names = FALSE)
md <- c("# Model choice: measurements chosen by next_measurement() against a fixed schedule",
        "",
        paste0("bench/next-measurement-model-choice.R, commit ",
               system("git rev-parse --short HEAD", intern = TRUE), ", ",
               format(Sys.time(), tz = "UTC", usetz = TRUE), "; ",
               round(proc.time()[["elapsed"]] - t0), " s on a shared 2-core machine."),
        "",
        "Measurements until the true model's probability reaches 0.99 (cap 150):",
        "",
        paste(knitr::kable(summary_table, format = "pipe", row.names = FALSE),
              collapse = "\n"))
writeLines(md, "bench/results/next-measurement-model-choice.md")
writeLines(md)
