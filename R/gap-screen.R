# The gap screen: does a fit without a discrepancy hide one? After sampling,
# finish_fit() weighs a gp_discrepancy() on the runs and the correlation grid
# point that carry the posterior, and warns when the data favour it.
#
# It is a lower bound, and cheap: the evidence of the model with a
# discrepancy summed over a subset of runs (and grid points), under their
# prior mass in the full model, is at most its evidence over all of them; the
# evidence without one is the fit's own, exact. So a large factor is a real
# one, and a small one may hide a discrepancy that other runs would show
# (then diagnose_gap() looks further).

# At most this many runs (those with the most posterior mass, covering all
# but 1e-6 of it when fewer do) and this many measured cells: beyond them the
# screen's eigen-decompositions cost more than the fit.
gap_screen_runs <- 500L
gap_screen_cells <- 400L

# The screen's result for a fit without a discrepancy: list(log_bf = the
# lower bound on the log Bayes factor, runs = how many runs it weighed,
# blocks and n_flagged = the base model's block checks), or NULL when it
# does not apply (too many cells, an improper evidence). Built from the
# fit's own problem (finish_fit()), so any route's fit gets it, and each run
# keeps the covariance it has in the fit (a predicted run its emulation
# error): the model with a discrepancy differs from the fit's by the
# discrepancy alone. A fit with a discrepancy weighs it exactly
# (discrepancy_evidence()): its screen holds the block checks alone
# (log_bf NA, `discrepancy` TRUE), which its warning reads (warn_gap()).
# Data that cannot weigh a gap (gap_weighable()) get `weighable` FALSE.
gap_screen <- function(fit) {
  if (!gap_weighable(fit$n_obs)) {
    return(list(log_bf = NA_real_, runs = 0L, blocks = NULL, n_flagged = 0L,
                weighable = FALSE))
  }
  n_cells <- sum(!is.na(fit$y_field))
  if (n_cells > gap_screen_cells) return(NULL)
  if (!is.null(fit$setup$discrepancy)) {
    blocks <- discrepancy_fit_blocks(fit)
    return(list(log_bf = NA_real_, runs = 0L, blocks = blocks, discrepancy = TRUE,
                n_flagged = if (is.null(blocks)) 0L else sum(blocks$flagged)))
  }
  log_mass_full <- attr(fit$exact, "log_mass")
  if (is.null(log_mass_full) || !is.finite(log_mass_full)) return(NULL)
  runs <- screen_runs(fit$exact$run)
  g <- which.max(fit$exact$grid$prob)
  # the fit has said what there is to say about its library and prior: the
  # screen's own problem stays quiet
  log_mass <- tryCatch(suppressWarnings(screen_log_mass(fit, runs, g),
                                        classes = "griddy_warning"),
                       griddy_error = function(e) NULL)
  if (is.null(log_mass)) return(NULL)
  # the subset's and the grid point's prior mass in the full model
  log_prior_mass <- log_sum_exp(fit$log_prior_run[runs]) + fit$log_prior_grid[g]
  log_mass_disc <- log_mass + log_prior_mass
  blocks <- screen_blocks(fit, runs)
  list(log_bf = log_mass_disc - log_mass_full, runs = length(runs), blocks = blocks,
       n_flagged = if (is.null(blocks)) 0L else sum(blocks$flagged))
}

# The fit's own leave-block-out checks (base_check(), as diagnose_gap() runs
# them, on the runs that carry the posterior): the block table of
# gap_where(), or NULL where they do not answer (block_check_applies()). A
# local gap, a second peak at one setting, is flagged here while a smooth
# discrepancy's evidence stays inconclusive.
screen_blocks <- function(fit, runs) {
  if (!block_check_applies(fit)) return(NULL)
  tryCatch(base_check(fit, NULL, gap_block_fdr, runs)$blocks,
           griddy_error = function(e) NULL)
}

# The block checks of a fit with a discrepancy: those of its base model
# (the fit without the discrepancy, as calibrate() without one would screen
# it), on the runs that carry that model's posterior. A local gap that a
# smooth discrepancy does not capture, and so does not win evidence for, is
# warned whichever fit the user made.
discrepancy_fit_blocks <- function(fit) {
  if (!block_check_applies(fit)) return(NULL)
  tryCatch({
    base <- no_discrepancy_problem(fit)
    runs <- screen_runs(grid_posterior(base, joint = FALSE)$run)
    base_check(base, NULL, gap_block_fdr, runs)$blocks
  }, griddy_error = function(e) NULL)
}

# Built once per session: gp_discrepancy() checks its grids each time, which
# took a third of a small calibrate() (it is the same object every time).
screen_discrepancy <- function() {
  if (is.null(screen_cache$discrepancy)) {
    screen_cache$discrepancy <- gp_discrepancy(ratio = gp_discrepancy()$ratio[-1])
  }
  screen_cache$discrepancy
}
screen_cache <- new.env(parent = emptyenv())

# The problem of the screen: library rows `runs` of a fit at its grid point
# g, with `discrepancy` added to the fit's noise pattern (its observed
# points, sd, groups and replicates), each run under the covariance it has
# in the fit (predicted_forms()).
screen_problem <- function(fit, runs, g, discrepancy = screen_discrepancy()) {
  lib <- fit$library
  sub <- runs_piece(lib_theta(lib)[runs, , drop = FALSE], lib_outputs(lib, runs), lib_x(lib),
                    lib_t(lib))
  pattern <- setup_noise_pattern(fit$setup, lib_n_out(lib), fit$prior)
  rho <- grid_rho(fit, g)
  # the discrepancy learns its sensitivities from the whole library, as the
  # full model's does (a subset's nearest runs differ, and so would the
  # model): around the best run under independent noise, which C holds
  # when the grid has the point rho = 0
  disc <- discrepancy_for_data(discrepancy, lib, fit$y_field, pattern, screen_best_run(fit))
  setup <- correlation_setup(sub, rho$x, rho$t, fit$setup$x_power, pattern, disc)
  # the replicates' constant of the log-determinant, which a setup does not
  # keep: grid point g of the fit has the same correlation and no
  # discrepancy. A fit in the Kronecker case (complete data, one group, no
  # sd: no pattern kept) has none, and its setup's log|R_g| is the one the
  # discrepancy's factors start from: no second setup is built
  if (!is.null(fit$setup$pattern)) {
    base <- correlation_setup(sub, rho$x, rho$t, fit$setup$x_power, pattern)
    setup$logdet <- setup$logdet + (fit$setup$logdet[g] - base$logdet[1])
  }
  C <- fold_extra_logdet(predicted_forms(lib, runs, fit$y_field, setup), fit$prior, fit$n_obs)
  new_griddy_problem(sub, fit$y_field, fit$prior, normalise_log_prob(fit$log_prior_run[runs]),
                     setup, C = C)
}

# The log evidence of the screen's model (library rows `runs` at grid point
# g with the screen's discrepancy): by the dense algebra of
# small_screen_log_mass() where it applies, else from screen_problem().
# `small`: whether to take the dense route where it applies (the tests
# compare the two).
screen_log_mass <- function(fit, runs, g, small = TRUE) {
  if (small && small_screen_applies(fit, runs)) return(small_screen_log_mass(fit, runs, g))
  grid_posterior(screen_problem(fit, runs, g), joint = FALSE)$log_mass
}

# Up to this many measured cells a Kronecker fit's screen is computed
# densely (small_screen_log_mass()): there an n x n eigen-decomposition per
# length scale costs less than the engine's setups (bench/calibrate-overhead.R).
small_screen_cells <- 64L

# Whether small_screen_log_mass() computes the screen of this fit: the
# Kronecker case (complete data, one noise group, no sd, no replicates: no
# noise pattern kept) at most small_screen_cells cells, and runs that were
# all simulated (a predicted run has a covariance of its own).
small_screen_applies <- function(fit, runs) {
  is.null(fit$setup$pattern) && length(fit$y_field) <= small_screen_cells &&
    length(predicted_parts(fit$library, runs)) == 0L
}

# screen_problem()'s log evidence, computed directly: with R = U'U the
# noise correlation of grid point g over the n cells and, per length scale
# l of the discrepancy, U^-T K_l U^-1 = V diag(d) V', each run's residual
# r (z = V' U^-T r) has r' (R + lambda K_l)^-1 r = sum_k z_k^2 / (1 + lambda
# d_k) and log|R + lambda K_l| = log|R| + sum_k log(1 + lambda d_k): the
# algebra of the engine's low-rank factors (discrepancy-engine.R), over n
# dimensions at once. The same kernels (discrepancy_kernels(): projected off
# the sensitivities learnt from the whole library), grid and priors as
# screen_problem()'s; equal to its log evidence to rounding (test-gap-screen.R).
small_screen_log_mass <- function(fit, runs, g, discrepancy = screen_discrepancy()) {
  lib <- fit$library
  n_out <- lib_n_out(lib)
  pattern <- setup_noise_pattern(fit$setup, n_out, fit$prior)
  disc <- discrepancy_for_data(discrepancy, lib, fit$y_field, pattern, screen_best_run(fit))
  points <- discrepancy_points(disc, lib)
  kernels <- discrepancy_kernels(lib, attr(points, "kernels"))
  U <- observed_noise_cholesky(fit$setup, g, lib_t(lib), seq_len(n_out),
                               list(seq_len(n_out)))[[1]]
  resid <- matrix(fit$y_field, length(runs), n_out, byrow = TRUE) - lib_outputs(lib, runs)
  Z <- t(backsolve(U, t(resid), transpose = TRUE))
  C <- matrix(0, length(runs), nrow(points))
  logdet <- rep(fit$setup$logdet[g], nrow(points))
  for (l in unique(points$kernel)) {
    X <- backsolve(U, kernels[[l]], transpose = TRUE)
    M <- t(backsolve(U, t(X), transpose = TRUE))
    e <- eigen((M + t(M)) / 2, symmetric = TRUE)
    d <- pmax(e$values, 0)
    at <- which(points$kernel == l)
    C[, at] <- (Z %*% e$vectors)^2 %*% (1 / (1 + outer(d, points$ratio[at])))
    logdet[at] <- logdet[at] + colSums(log1p(outer(d, points$ratio[at])))
  }
  n <- fit$n_obs
  assert_misfit_scale(C, fit$y_field, n)
  if (fit$prior$rate == 0 && min(C) <= 0) {
    griddy_abort("A library run reproduces the field data exactly.")
  }
  post <- grid_posterior_cpp(C, fit$prior$shape + n / 2, fit$prior$rate, logdet,
                             normalise_log_prob(fit$log_prior_run[runs]), points$log_prior,
                             FALSE, 1L)
  post$log_norm + log_evidence_constant(fit$prior, n)
}

# The run that fits best under independent noise, which C holds when the
# grid has the point rho = 0 (NULL otherwise: the discrepancy then finds it).
screen_best_run <- function(fit) {
  zero <- which(rowSums(as.matrix(fit$grid) != 0) == 0)[1]
  if (!is.na(zero)) which.min(fit$C[, zero])
}

# The runs that carry all but 1e-6 of the posterior, at most
# gap_screen_runs of them (at least 2, the least a library holds).
screen_runs <- function(post) {
  # runs below 1e-6 / N hold less than 1e-6 together: one pass leaves them
  # out before anything is sorted (10^6 runs take no sort)
  candidates <- which(post >= 1e-6 / length(post))
  if (length(candidates) < 2L) candidates <- seq_along(post)
  k <- min(gap_screen_runs, length(candidates))
  top <- candidates[order(post[candidates], decreasing = TRUE)[seq_len(k)]]
  enough <- which(cumsum(post[top]) >= 1 - 1e-6)[1]
  top[seq_len(max(2L, if (is.na(enough)) k else enough))]
}

# The correlation parameters of grid point g of a fit, as rho_x (one value
# per x column) and rho_t arguments.
grid_rho <- function(fit, g) {
  setup <- fit$setup
  combo <- expand.grid(setup$rho_x, KEEP.OUT.ATTRS = FALSE)[setup$gx[g], , drop = FALSE]
  names(combo) <- sub("^rho_x_", "", names(combo))
  list(x = as.list(combo), t = setup$rho_t[setup$gt[g]])
}

# Whether the screen found a gap it can vouch for (gap_shown(): its bound on
# the log Bayes factor, or the block checks) on a fit whose library resolves
# the posterior. (Between coarse runs the misfit of the nearest run looks
# like a gap as well, so a fit limited by the library's resolution, which is
# warned of already, gets no gap warning: refine() it first.)
screen_shows_gap <- function(fit) {
  screen <- fit$gap_screen
  # a fit with a discrepancy says it (warn_gap())
  if (is.null(screen) || isTRUE(screen$discrepancy) ||
        !gap_shown(screen$log_bf, screen$n_flagged)) return(FALSE)
  tab <- resolution_limited(fit)
  !any(tab$limited & !tab$constant)
}

# Whether the screen found that the data cannot weigh a gap (gap_weighable()).
screen_unweighable <- function(fit) isFALSE(fit$gap_screen$weighable)

# finish_fit()'s warning when the screen finds a gap.
warn_gap_screen <- function(fit) {
  if (!screen_shows_gap(fit)) return(invisible(NULL))
  griddy_warn(gap_screen_message(fit$gap_screen, fit$library, emulation_caveat(fit)),
              class = "gap")
}

# The screen's finding in words: the evidence, the blocks flagged (where, by
# their x values and t range), what theta then is, and why its number is
# smaller than diagnose_gap()'s.
gap_screen_message <- function(screen, library = NULL, caveat = NULL) {
  log_bf <- screen$log_bf
  flagged <- if (!is.null(screen$blocks)) screen$blocks[screen$blocks$flagged, , drop = FALSE]
  evidence <- paste0("log Bayes factor of at least ", format(log_bf, digits = 3), " (",
                     evidence_words(log_bf), ")")
  paste0("The field data show structure the model has no term for: ",
         if (gap_shown(log_bf)) {
           paste0("a Gaussian-process discrepancy is favoured by a ", evidence)
         } else {
           paste0("the evidence for a smooth Gaussian-process discrepancy is weak (a ",
                  evidence, ")")
         },
         if (NROW(flagged) > 0L) {
           paste0(if (gap_shown(log_bf)) ", and" else ", but",
                  " the model's leave-block-out checks flag ", nrow(flagged), " block",
                  if (nrow(flagged) > 1L) "s", " (", flagged_blocks_text(flagged, library),
                  ") as a local misfit")
         },
         "; ", gap_theta_sentence, " (the value that brings the simulator closest to data ",
         "it cannot match), and until the gap is modelled its intervals may be narrow and ",
         "off. It is a gap between the simulator and reality, or noise correlated ",
         "over x or t (try the `rho_x` and `rho_t` grids). Fit it with ",
         "`discrepancy = gp_discrepancy()`, or look for its cause with diagnose_gap(). ",
         screen_number_note(),
         if (!is.null(caveat)) paste0(" ", caveat))
}

# Why the screen's factor is smaller than the others griddy reports.
screen_number_note <- function() {
  paste0("(The factor is a lower bound from the runs that carry the posterior: a fit with ",
         "`discrepancy = gp_discrepancy()` computes it exactly over all runs, so reports at ",
         "least as much, and diagnose_gap() on a refined library.)")
}

# Flagged blocks `flagged` (gap_where()'s rows) as "x = ..., t a-b", at most
# three of them.
flagged_blocks_text <- function(flagged, library = NULL) {
  x <- if (!is.null(library)) lib_x(library)
  where <- vapply(seq_len(nrow(flagged)), function(i) {
    k <- flagged$x[i]
    setting <- if (is.null(x)) paste("setting", k) else {
      paste(names(x), format(unlist(x[k, , drop = TRUE]), digits = 3), sep = " = ",
            collapse = ", ")
    }
    span <- if (flagged$from[i] == flagged$to[i]) format(flagged$from[i], digits = 3) else
      paste0(format(flagged$from[i], digits = 3), " to ", format(flagged$to[i], digits = 3))
    paste0(setting, ", t ", span)
  }, character(1))
  paste0(paste(utils::head(where, 3L), collapse = "; "),
         if (length(where) > 3L) paste0("; and ", length(where) - 3L, " more"))
}

# What a gap found on predicted runs worse than the noise may be instead:
# the emulator's error beyond its estimate (warned of already).
emulation_caveat <- function(fit) {
  ratio <- emulation_error(fit)
  if (is.null(ratio) || !is.finite(ratio) || ratio <= emulation_error_threshold) return(NULL)
  paste0("(The runs near the posterior were predicted with an error ", format(ratio, digits = 2),
         " times the noise: part of the gap may be that error; refine with the simulator.)")
}
