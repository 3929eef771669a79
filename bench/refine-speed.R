# refine() without a simulator on the thesis's working case: the piston
# stand-in's 39^3 = 59,319-run library, 54 data points (27 locations x 2
# conditions), independent errors. Times one round (emulator, predicted
# runs, their quadratic forms with the prediction error, exact posterior),
# the whole refine() (rounds + the final 35,000-iteration sampling), and
# what the prediction error costs: the quadratic forms of the predicted runs
# with and without the error term, and the intervals with and without it.
#
# Run: Rscript bench/refine-speed.R   (from the package root); writes
# bench/results/refine-speed.txt
if (requireNamespace("pkgload", quietly = TRUE) && file.exists("DESCRIPTION")) {
  pkgload::load_all(".", quiet = TRUE)
} else {
  library(griddy)
}
source("bench/helpers.R")
out <- character()
say <- function(...) {
  line <- paste0(...)
  cat(line, "\n")
  out <<- c(out, line)
}
say(machine_note())

build <- time_it(lib <- piston_library(39, locations = 1:27, condition = c("full", "part")))
field <- piston_field_data(54, seed = 2023)
say("library: ", lib_n_runs(lib), " runs x ", lib_n_out(lib), " outputs, built in ",
    format(build, digits = 3), " s")
t_fit <- time_it(fit <- suppressWarnings(calibrate(lib, field, seed = 1, progress = FALSE)))
say("calibrate() (35,000 iterations): ", format(t_fit, digits = 3), " s")
tab <- resolution_limited(fit)
say("plain fit: effective values per coefficient ",
    paste(format(tab$effective_values, digits = 3), collapse = ", "))

# one round, step by step
state <- refine_state(fit)
per_round <- default_runs_per_round(lib_theta(lib))
set.seed(1)
t_box <- time_it(box <- refine_box(state))
theta_new <- latin_hypercube(per_round, box, names(lib_theta(lib)))
t_em <- time_it(em <- round_emulator(state, box))
t_pred <- time_it(batch <- emulated_batch(em, theta_new, state))
round <- list(box = box, n = per_round, source = "emulator", error = batch$error)
t_ext <- time_it(problem <- extend_problem(fit, theta_new, batch$y, round, batch$rel_var))
t_state <- time_it(state2 <- refine_state(problem))
say("one round of ", per_round, " predicted runs: box ", format(t_box, digits = 2),
    " s, emulator + leave-one-out ", format(t_em, digits = 3), " s, predictions ",
    format(t_pred, digits = 3), " s, quadratic forms and prior weights ",
    format(t_ext, digits = 3), " s, exact posterior ", format(t_state, digits = 3),
    " s; total ", format(t_box + t_em + t_pred + t_ext + t_state, digits = 3), " s")
say("emulator method: ", em$method, "; error model rank ", length(batch$error$lambda))

# the prediction error's cost: quadratic forms with and without it
lib2 <- problem$library
which_new <- seq(nrow(lib2$added$y) - per_round + 1L, nrow(lib2$added$y))
t_with <- time_it(for (i in 1:20) added_quad_forms(lib2, which_new, fit$y_field, fit$setup))
plain <- lib2
plain$rounds[[1]]$error <- NULL
t_without <- time_it(for (i in 1:20) added_quad_forms(plain, which_new, fit$y_field, fit$setup))
say("quadratic forms of ", per_round, " predicted runs: ", format(1000 * t_with / 20, digits = 3),
    " ms with the prediction error, ", format(1000 * t_without / 20, digits = 3), " ms without")

# the whole refine(), and the intervals with and without the error term
t_refine <- time_it(refined <- refine(fit, NULL, max_runs = 5000, seed = 1, progress = FALSE))
say("refine(fit, max_runs = 5000): ", format(t_refine, digits = 3), " s (", refined$refinement$runs_added,
    " runs in ", refined$refinement$rounds, " rounds, ", refined$refinement$reason,
    "; the final sampling ", format(sum(refined$runtime), digits = 3), " s of it)")
s <- summary(refined)
truth <- c(htc_undercrown = 1000, htc_gallery1 = 3000, htc_gallery2 = 2000)
th <- s[s$parameter %in% names(truth), ]
say("refined 95% intervals: ", paste0(th$parameter, " [", format(th$lower, digits = 5), ", ",
                                      format(th$upper, digits = 5), "] (truth ",
                                      truth[th$parameter], ")", collapse = "; "))
no_error <- refined$library
for (r in seq_along(no_error$rounds)) no_error$rounds[[r]]$error <- NULL
ex0 <- posterior_exact(no_error, field)
tab0 <- resolution_table(ex0$run, lib_theta(no_error))
say("same runs without the prediction error: ", paste0(tab0$parameter, " [",
    format(tab0$lower, digits = 5), ", ", format(tab0$upper, digits = 5), "]", collapse = "; "))
dir.create("bench/results", showWarnings = FALSE)
writeLines(out, "bench/results/refine-speed.txt")
