# refine()'s runs without a simulator: predicted from the library through
# the emulation-error contract of library.R (lib_emulator(),
# lib_predict()).
#
# Where a round's runs go follows the rounds with a simulator: up to three
# parameters a Latin hypercube in the round's box (refine_box()), from four
# (uses_proposal()) draws from the proposal fitted to the weighted library
# (round_design(), refine-proposal.R). A box of the marginals' ranges is
# mostly empty of posterior mass in many parameters (issue 35: Al-5083's 11
# parameters rested on 22.6 effective runs of the 220 needed after 26,000
# predicted runs in boxes); the proposal follows the posterior's correlations
# and modes, and its density enters the runs' prior weights as a simulated
# round's does. The emulator of the proposal rounds is fitted once, over the
# whole library's range (a proposal's t tails and defensive share reach all
# of it), on up to `proposal_emulator_max_runs` simulated runs, and its
# error is scaled to its leave-one-out variance (proposal_round_emulator()).

# One round of n predicted runs: list(state, emulator), the emulator kept for
# the next round while it still covers the round's runs. `proposals` FALSE
# keeps the boxes in any dimension (diagnose_gap()'s matched resolution).
predicted_round <- function(state, emulator, n, proposals = TRUE) {
  library <- state$problem$library
  if (proposals && uses_proposal(library)) {
    design <- round_design(state, n)
    theta_new <- design$theta
    round <- list(box = NULL, proposal = design$round$proposal)
    if (is.null(emulator)) emulator <- proposal_round_emulator(state)
  } else {
    box <- refine_box(state)
    theta_new <- latin_hypercube(n, box, names(lib_theta(library)))
    round <- list(box = box)
    if (is.null(emulator) || !box_inside(box, emulator$refine_region)) {
      emulator <- round_emulator(state, box)
    }
  }
  batch <- emulated_batch(emulator, theta_new, state)
  round <- c(round, list(n = n, source = "emulator", error = batch$error))
  state <- refine_state(extend_problem(state$problem, theta_new, batch$y, round,
                                       batch$rel_var))
  list(state = restate_noise_var(state), emulator = emulator)
}

# The emulator of a round: built from the library's simulated runs over a
# region that leaves room for the boxes of later rounds (half the box's
# width on each side, inside the library's range). An emulated library
# predicts with its own emulator of its design runs.
round_emulator <- function(state, box) {
  library <- state$problem$library
  range0 <- library_box(lib_base(library))
  pad <- (box[2, ] - box[1, ]) / 2
  region <- rbind(pmax(box[1, ] - pad, range0[1, ]), pmin(box[2, ] + pad, range0[2, ]))
  colnames(region) <- names(lib_theta(library))
  region_emulator(library, region)
}

# The emulator's own errors name its arguments (`region`), which the user of
# refine() never gave: say what refine() was doing instead.
region_emulator <- function(library, region, ...) {
  tryCatch(lib_emulator(library, as.data.frame(region), ...), griddy_error = function(e) {
    griddy_abort("refine() without a simulator predicts new runs from the library's ",
                 "simulated runs, but could not build an emulator of them around the ",
                 "posterior (", paste0(colnames(region), " ", format(region[1, ], digits = 4),
                                       " to ", format(region[2, ], digits = 4),
                                       collapse = ", "),
                 "): the runs there are too few or do not span it. Give refine() the ",
                 "simulator (`simulator =`), or calibrate on a library with more runs there.",
                 class = "emulation")
  })
}

# The most simulated runs the proposal rounds' Gaussian process is fitted
# on. Its cost grows with their cube; in many parameters every run counts
# (Al-5083's 1,000 runs in 11 parameters lie a quarter of the range apart),
# and the fit is made once per refine().
proposal_emulator_max_runs <- 1000L

# The emulator of the proposal rounds, over the whole library's range.
# A "gp" emulator's relative variance is scaled to its mean leave-one-out
# variance on its runs rather than to its largest in the region: the error
# model V is the second moment of those leave-one-out residuals, so a
# prediction as uncertain as a typical left-out run carries V itself. (Over
# an 11-dimensional range the largest variance, at the corners, is several
# times a left-out run's, and scaling by it shrank the error where the
# posterior is.) The relative variance stays capped at 1: a run-dependent
# error that grew without bound would pull the posterior to where the
# emulator knows least (see emulation.R).
proposal_round_emulator <- function(state) {
  library <- state$problem$library
  region <- library_box(lib_base(library))
  colnames(region) <- names(lib_theta(library))
  em <- region_emulator(library, region, max_runs = proposal_emulator_max_runs)
  if (identical(em$method, "gp") && !is.null(em$fit)) {
    loo_var <- mean(ppgasp_loo(em$fit, em$vary, length(em$rows))$var)
    if (is.finite(loo_var) && loo_var > 0) em$var_max <- loo_var
  }
  em
}

# Predicted outputs, their relative variances and the round's error model
# (on the scale of the round's posterior mean noise variance).
emulated_batch <- function(emulator, theta_new, state) {
  lib_predict(emulator, theta_new, posterior_noise_var(state))
}
