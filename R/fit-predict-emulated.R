# predict() at new x settings without a simulator (issue 34, item 1): an
# emulated library's emulator over (x, theta) stands in for the simulator
# where its design reaches, and its predictive sd joins the bands as the
# emulation error. fit-predict-new.R calls design_reach() and, when every
# new setting is reached, runs emulated_outputs() where it would run the
# simulator.
#
# "Reaches": the library was built by emulated_library() from design runs
# with x settings, and every new setting lies inside the design's range of
# each x column, give or take 5% of its width (the rule by which
# emulated_library() warns of extrapolation, warn_extrapolation()). Beyond
# it the Gaussian process reverts to its mean and its error model, measured
# inside the design, understates the error, so a band from it would be
# narrow where it should be wide. Inside the range the GP's predictive sd
# grows where the design is sparse (a joint design whose x settings vary
# with theta leaves corners of the (x, theta) box empty), and the band with
# it.

# The emulated library behind `lib` (itself, or a refined library's base),
# or NULL.
design_library <- function(lib) {
  if (inherits(lib, "refined_library")) lib <- lib$base
  if (inherits(lib, "emulated_library")) lib else NULL
}

# Whether the design of `lib` reaches the new settings `x_new` (a data
# frame over the library's x columns): list(ok, why), `why` the sentence
# predict()'s error gives when it does not.
design_reach <- function(lib, x_new) {
  em <- design_library(lib)
  if (is.null(em)) {
    return(list(ok = FALSE, why = paste0(
      "this library (", class(lib)[1], ") was not emulated from a design of runs, so ",
      "there is no emulator over x to predict with")))
  }
  dx <- emulated_design(em)$x
  far <- vapply(names(x_new), function(nm) {
    lo <- min(dx[[nm]])
    hi <- max(dx[[nm]])
    slack <- max(0.05 * (hi - lo), 1e-8 * max(1, abs(lo), abs(hi)))
    beyond <- which(pmax(lo - x_new[[nm]], x_new[[nm]] - hi, 0) > slack)
    if (length(beyond) == 0L) return("")
    paste0(nm, " = ", show_some(format(x_new[[nm]][beyond], digits = 4)),
           " outside the design's [", format(lo, digits = 4), ", ", format(hi, digits = 4), "]")
  }, "")
  far <- far[nzchar(far)]
  if (length(far) == 0L) return(list(ok = TRUE, why = NULL))
  list(ok = FALSE, why = paste0(
    "the library's emulator does not reach them: ", paste(far, collapse = "; "),
    " (beyond 5% of its width the emulator extrapolates)"))
}

# The emulator's outputs at the runs `theta` (a data frame) and the new
# settings `x_new`: a matrix in the simulator's layout (one row per run,
# blocks of t by setting) with attribute "sd", the emulator's predictive sd
# of each output. The library's own emulator when it is joint (x, theta) ->
# outputs; a complete design's emulator maps theta to the library's
# settings only, so one is fitted to the design for the new settings
# (design_gp() picks its form: theta -> outputs if the design was run at
# every new setting, else joint).
emulated_outputs <- function(lib, theta, x_new) {
  em <- design_library(lib)
  gp <- lib_design_emulator(em)
  x_new <- as.matrix(x_new[colnames(gp$settings)])
  if (gp$mode == "theta") {
    d <- emulated_design(em)
    gp <- design_gp(list(theta = as.matrix(d$theta), y = d$y, x = as.matrix(d$x)), x_new)
  }
  theta <- as.matrix(theta)[, gp$theta_names, drop = FALSE]
  # chunks of runs: ppgasp holds a runs x design-runs matrix per call
  chunks <- split(seq_len(nrow(theta)), (seq_len(nrow(theta)) - 1L) %/% 2000L)
  parts <- lapply(chunks, function(rows) emulator_at(gp, theta[rows, , drop = FALSE], x_new))
  structure(unname(do.call(rbind, lapply(parts, `[[`, "mean"))),
            sd = unname(do.call(rbind, lapply(parts, `[[`, "sd"))))
}

# emulated_outputs() for one chunk of runs: list(mean, sd), the simulator's
# layout.
emulator_at <- function(gp, theta, x_new) {
  if (gp$mode == "theta") return(emulator_mean_sd(gp, gp_scale(gp, theta)))
  parts <- lapply(seq_len(nrow(x_new)), function(k) {
    emulator_mean_sd(gp, gp_scale(gp, cbind(x_new[rep(k, nrow(theta)), , drop = FALSE], theta)))
  })
  list(mean = do.call(cbind, lapply(parts, `[[`, "mean")),
       sd = do.call(cbind, lapply(parts, `[[`, "sd")))
}

# ppgasp's mean and predictive sd of every output at scaled inputs z
# (outputs constant over the design: that constant, sd 0). An sd ppgasp
# cannot give (near-singular runs) is the largest it gave: unknown error is
# not small error.
emulator_mean_sd <- function(gp, z) {
  mean <- matrix(gp$constant, nrow(z), length(gp$constant), byrow = TRUE)
  sd <- mean * 0
  if (!is.null(gp$fit)) {
    pred <- RobustGaSP::predict.ppgasp(gp$fit, z)
    s <- pred$sd
    s[!is.finite(s)] <- max(c(s[is.finite(s)], 0))
    mean[, gp$vary] <- pred$mean
    sd[, gp$vary] <- s
  }
  list(mean = mean, sd = sd)
}
