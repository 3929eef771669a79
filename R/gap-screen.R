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
  problem <- tryCatch(suppressWarnings(screen_problem(fit, runs, g), classes = "griddy_warning"),
                      griddy_error = function(e) NULL)
  if (is.null(problem)) return(NULL)
  # the subset's and the grid point's prior mass in the full model
  log_prior_mass <- log_sum_exp(fit$log_prior_run[runs]) + fit$log_prior_grid[g]
  log_mass_disc <- grid_posterior(problem, joint = FALSE)$log_mass + log_prior_mass
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
  zero <- which(rowSums(as.matrix(fit$grid) != 0) == 0)[1]
  best <- if (!is.na(zero)) which.min(fit$C[, zero])
  disc <- discrepancy_for_data(discrepancy, lib, fit$y_field, pattern, best)
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
