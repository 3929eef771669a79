# Is the library fine and wide enough for this posterior? Three numbers:
# the effective number of runs carrying the posterior (1 / sum p^2), the
# posterior mass on runs at the edge of the library's theta range, and the
# share of the single most probable run.

# A run is at the edge of column j if its value lies within half a design step
# of the column's minimum or maximum. The step is the range over (k - 1), with
# k the per-dimension resolution of a space-filling design of N runs in p
# dimensions, min(distinct values, N^(1/p)): the grid spacing of a full
# factorial, about range / sqrt(N) per dimension for a 2-D Latin hypercube.
edge_runs <- function(theta) {
  n_runs <- nrow(theta)
  k_all <- n_runs^(1 / ncol(theta))
  at_edge <- lapply(theta, function(v) {
    k <- min(length(unique(v)), ceiling(k_all - 1e-9))
    half_step <- (max(v) - min(v)) / (2 * max(k - 1, 1))
    v <= min(v) + half_step | v >= max(v) - half_step
  })
  Reduce(`|`, at_edge)
}

run_adequacy <- function(p, theta) {
  top <- which.max(p)
  edge <- edge_runs(theta)
  list(effective_runs = 1 / sum(p^2), edge_mass = sum(p[edge]),
       top_run = top, top_share = p[top], top_theta = theta[top, , drop = FALSE])
}

# Posterior probability of each run: sampled frequencies, and exact values
# from the stored quadratic forms.
run_probabilities <- function(fit) {
  n_runs <- lib_n_runs(fit$library)
  sampled <- tabulate(fit$draws$run, nbins = n_runs) / nrow(fit$draws)
  exact <- exact_from_problem(fit)$run
  list(sampled = sampled, exact = exact)
}

library_adequacy <- function(fit) {
  p <- run_probabilities(fit)
  list(sampled = run_adequacy(p$sampled, lib_theta(fit$library)),
       exact = run_adequacy(p$exact, lib_theta(fit$library)),
       tv_distance = sum(abs(p$sampled - p$exact)) / 2)
}

single_run_threshold <- 0.9

warn_single_run <- function(fit) {
  # sampled frequencies only: the exact posterior would take several copies of C
  p <- tabulate(fit$draws$run, nbins = lib_n_runs(fit$library)) / nrow(fit$draws)
  top <- which.max(p)
  if (p[top] >= single_run_threshold) {
    griddy_warn("The posterior sits on one library run: run ", top, " holds ",
                 format(100 * p[top], digits = 3), "% of the draws. Its intervals show ",
                 "the library's resolution, not the data's uncertainty; refine the ",
                 "library around this run (see summary()).")
  }
}

format_adequacy <- function(adequacy) {
  s <- adequacy$sampled
  e <- adequacy$exact
  lines <- c(
    paste0("Library adequacy: effective number of runs ", format(s$effective_runs, digits = 3),
           " (exact ", format(e$effective_runs, digits = 3), "); mass at the edge of the ",
           "theta range ", format(s$edge_mass, digits = 2), " (exact ",
           format(e$edge_mass, digits = 2), ")."),
    paste0("Draws vs exact posterior over runs: total-variation distance ",
           format(adequacy$tv_distance, digits = 2), ".")
  )
  if (s$top_share >= single_run_threshold) {
    lines <- c(lines, paste0(
      "Warning: the posterior sits on run ", s$top_run, " (",
      format(100 * s$top_share, digits = 3), "% of draws: ",
      paste0(names(s$top_theta), " = ", vapply(s$top_theta, format, "", digits = 4),
             collapse = ", "),
      "); intervals reflect the library's resolution, not the data."))
  }
  if (e$edge_mass > 0.05) {
    lines <- c(lines, paste0(
      "Warning: ", format(100 * e$edge_mass, digits = 2), "% of the posterior lies on runs ",
      "at the edge of the library; the truth may lie outside its range."))
  }
  lines
}
