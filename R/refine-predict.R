# refine()'s runs without a simulator: predicted from the library through
# the emulation-error contract of library.R (lib_emulator(),
# lib_predict()).

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
  # the emulator's own errors name its arguments (`region`), which the user
  # of refine() never gave: say what refine() was doing instead
  tryCatch(lib_emulator(library, as.data.frame(region)), griddy_error = function(e) {
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

# Predicted outputs, their relative variances and the round's error model
# (on the scale of the round's posterior mean noise variance).
emulated_batch <- function(emulator, theta_new, state) {
  lib_predict(emulator, theta_new, posterior_noise_var(state))
}
