# The three files of the vignette "Your own data" (vignettes/your-own-data.Rmd):
# a ball drop study in the Los Alamos simobs layout.
#   ball_design.csv  40 simulator runs, a Latin hypercube over the ball's
#                    radius (the control setting x) and theta = (drag,
#                    gravity) jointly: every run at its own radius;
#   ball_simobs.csv  each run's fall times at 7 heights (one row per run);
#   ball_expobs.csv  four balls dropped from the 7 heights, some heights not
#                    timed (empty cells).
# The field data come from the same physics with drag = 0.47 and gravity =
# 9.81, plus what the simulator leaves out: the timer starts `delay` = 0.04 s
# before the ball is released. Timing noise sd 0.02 s.
#
# Run from the package root: Rscript data-raw/your-own-data.R
source("inst/extdata/ball_drop.R")
set.seed(20261123)
heights <- c(5, 10, 20, 30, 40, 50, 60)
n_runs <- 40
slice <- function(n, lower, upper) lower + (upper - lower) * (sample.int(n) - stats::runif(n)) / n
design <- data.frame(radius = slice(n_runs, 0.04, 0.2), drag = slice(n_runs, 0.2, 1),
                     gravity = slice(n_runs, 9.5, 10.1))
simobs <- ball_drop(design[c("drag", "gravity")], design["radius"], heights)
colnames(simobs) <- paste0("h", heights)

balls <- data.frame(radius = c(0.05, 0.08, 0.12, 0.17))
truth <- data.frame(drag = 0.47, gravity = 9.81)
delay <- 0.04
times <- ball_drop(truth[rep(1, nrow(balls)), ], balls, heights) + delay
expobs <- times + stats::rnorm(length(times), sd = 0.02)
expobs[cbind(c(1, 2, 2, 3, 4), c(7, 1, 6, 4, 2))] <- NA
colnames(expobs) <- paste0("h", heights)

write_csv <- function(d, file) {
  utils::write.csv(signif(d, 6), file.path("inst/extdata", file), row.names = FALSE, na = "")
}
write_csv(design, "ball_design.csv")
write_csv(as.data.frame(simobs), "ball_simobs.csv")
write_csv(cbind(balls, expobs), "ball_expobs.csv")
