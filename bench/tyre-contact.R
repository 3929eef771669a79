# The tyre stand-in's contact events located within the time step (issue 35,
# item 4) against the fixed-step code it replaced (commit 9daa721): accuracy,
# smoothness of the likelihood in k and c, and speed.
#
# * Accuracy: 24 Latin-hypercube (k, c) over table 5.1's ranges, three cleat
#   heights, 500 samples each, for the patch, disc and point contacts (Fiala)
#   and the PAC2002-style disc tyre (the chapter 5 data's model). Max and rms
#   difference of Fz (N), old against new at the default step (1e-5 s), and
#   each against a fine-step reference (the new code at 1/10 of the step,
#   1e-6 s; the old code at that step is shown against it too: both
#   approximate the same solution).
# * Smoothness: the log likelihood (noise integrated out, n/2 log SS) of the
#   chapter 5 PAC2002-style data along k (+-0.1 N/mm, 41 values) and c
#   (+-0.001 N s/mm) through the disc fit's most probable run of the shipped
#   nine-parameter fit before this change (k 489.1 N/mm, c 1.5025 N s/mm),
#   each code with its own data; largest jump between neighbours, and the
#   largest second difference (a parabola's is constant and tiny here).
# * Speed: runs per second (CPU time, 24 runs x 3 heights, at the default
#   step), old and new, both compiled by sourceCpp (-O2).
#
# Usage, from the package root:  Rscript bench/tyre-contact.R
# Writes bench/results/tyre-contact.csv (accuracy and speed) and
# bench/results/tyre-contact-scan.csv (the scans).
pkgload::load_all(".", quiet = TRUE)
library(data.table)

# the old code (from git) and the new one, both compiled the same way
# (sourceCpp, R's default -O2; pkgload::load_all() compiles without
# optimisation, which would make the comparison of speed unfair)
compile <- function(src) {
  file <- tempfile(fileext = ".cpp")
  writeLines(c("// [[Rcpp::depends(RcppArmadillo)]]", src), file)
  env <- new.env()
  Rcpp::sourceCpp(file, env = env)
  env
}
old <- compile(system2("git", c("show", "9daa721:src/tyre_model.cpp"), stdout = TRUE))
new <- compile(readLines("src/tyre_model.cpp"))

sim <- function(code, theta, contact, model = "fiala", steps = 100, heights = tyre_cleat_heights()) {
  rig <- tyre_rig(steps_per_sample = steps)
  s <- tyre_settings(model, contact, 20, 0, tyre_pac2002()$p0, tyre_pac2002(), rig)
  f <- if (code == "old") old$tyre_sim_cpp else new$tyre_sim_cpp
  f(cbind(theta[, 1] * 1000, theta[, 2] * 1000), heights / 1000, s)
}

set.seed(35)
n <- 24
theta <- cbind(k = 50 + 750 * (sample.int(n) - runif(n)) / n,
               c = 5 * (sample.int(n) - runif(n)) / n)
cases <- list(list(contact = "patch", model = "fiala"), list(contact = "disc", model = "fiala"),
              list(contact = "point", model = "fiala"), list(contact = "disc", model = "pac2002"))
acc <- rbindlist(lapply(cases, function(cs) {
  run <- function(code, steps) sim(code, theta, cs$contact, cs$model, steps)
  cpu <- function(expr) system.time(expr)[["user.self"]]
  t_old <- cpu(y_old <- run("old", 100))
  t_new <- cpu(y_new <- run("new", 100))
  ref <- run("new", 1000)
  y_old_fine <- run("old", 1000)
  d <- function(a, b) c(max = max(abs(a - b)), rms = sqrt(mean((a - b)^2)))
  pairs <- list(`old vs new` = d(y_old, y_new), `old vs reference` = d(y_old, ref),
                `new vs reference` = d(y_new, ref),
                `old at reference step vs reference` = d(y_old_fine, ref))
  out <- data.table(contact = cs$contact, model = cs$model, comparison = names(pairs),
                    max_abs_N = vapply(pairs, `[[`, 0, "max"),
                    rms_N = vapply(pairs, `[[`, 0, "rms"),
                    runs_per_s_old = 3 * n / t_old, runs_per_s_new = 3 * n / t_new)
  print(out)
  out
}))

# likelihood scans through the old nine-parameter disc fit's most probable run
centre <- c(k = 489.1044, c = 1.502486)
half <- c(k = 0.1, c = 0.001)
scan <- rbindlist(lapply(c("old", "new"), function(code) {
  field <- sim(code, cbind(450, 1.5), "disc", "pac2002")
  set.seed(502)
  obs <- as.vector(field) + rnorm(length(field), sd = 60)
  rbindlist(lapply(names(half), function(p) {
    at <- centre[[p]] + seq(-half[[p]], half[[p]], length.out = 41)
    th <- matrix(centre, 41, 2, byrow = TRUE)
    th[, match(p, names(centre))] <- at
    y <- sim(code, th, "disc")
    ss <- rowSums((y - rep(obs, each = nrow(y)))^2)
    data.table(code = code, parameter = p, offset = at - centre[[p]],
               log_lik = -length(obs) / 2 * log(ss / min(ss)))
  }))
}))
rough <- scan[, .(largest_jump = max(abs(diff(log_lik))),
                  largest_second_difference = max(abs(diff(log_lik, differences = 2))),
                  local_maxima = sum(diff(sign(diff(log_lik))) < 0)), by = .(code, parameter)]
print(rough)
fwrite(acc, "bench/results/tyre-contact.csv")
fwrite(merge(scan, rough, by = c("code", "parameter")), "bench/results/tyre-contact-scan.csv")
