# The one way a fit is finished: every route that returns a griddy_fit
# (calibrate(), refine(), and the fit refine() hands back in an error) draws
# its chains with sample_problem() and then calls finish_fit(), so each
# carries the same checks and gives the same warnings. new_griddy_fit()
# has stored the exact posterior's margins, their resolution table and the
# chains' diagnostics; here the gap screen is added (built from the fit's
# own problem, see gap_screen()), and the warnings are given:
#
# * resolution: `resolution(fit)`, calibrate()'s warn_resolution() by
#   default; refine() passes its own, which says why its rounds stopped
#   short, so a refined fit is warned once;
# * convergence (warn_convergence());
# * emulation: refine()'s when it predicted runs (warn_emulation(); an
#   emulated library warns when its misfit table is computed, for
#   posterior_exact() too);
# * a gap: the fit's discrepancy (warn_gap()), or the screen of a fit
#   without one (warn_gap_screen()).
#
# `warn = FALSE` runs the checks without the warnings (the fit an error
# carries). The seconds taken count in fit$runtime[["checks"]].
finish_fit <- function(fit, resolution = warn_resolution, warn = TRUE) {
  force(fit)  # a lazy `fit` would be sampled inside the checks' time
  start <- proc.time()[["elapsed"]]
  fit$gap_screen <- gap_screen(fit)
  if (warn) {
    resolution(fit)
    warn_convergence(fit)
    warn_emulation(fit$refinement$emulation_error)
    warn_gap(fit)
    warn_gap_screen(fit)
  }
  fit$runtime[["checks"]] <- fit$runtime[["checks"]] + proc.time()[["elapsed"]] - start
  fit
}
