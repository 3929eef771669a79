# plot(fit, "ppc", newdata =) with settings the library does not hold
# (issue 34, item 1): the posterior predictive at the library's settings
# and the prediction at the new ones (predict(), through the simulator or an
# emulated library's emulator) on one figure, the new settings marked.

# The library's settings and newdata's new ones, predicted in one call
# (the library's rows are today's answer): with one output per setting and
# one x column, against x (a continuous axis, the bands joined across the
# settings, the new settings' means in orange, the calibrated range between
# dashed lines); otherwise one panel per setting against t (or against the
# settings' labels), the new settings' panels titled "(new)".
plot_ppc_new <- function(fit, newdata, level = 0.95, discrepancy = has_discrepancy(fit), ...) {
  lib <- predicted_library(fit)
  x_lib <- lib_x(lib)
  nd <- as.data.frame(as_numeric_matrix(newdata[names(x_lib)], "newdata"))
  all <- unique(rbind(x_lib, nd[is.na(match_setting_rows(nd, x_lib)), , drop = FALSE]))
  rownames(all) <- NULL
  pred <- predict(fit, newdata = all, level = level, discrepancy = discrepancy, ...)
  pred$new <- is.na(pred[[setting_column(lib)]])
  route <- if (is.null(list(...)$simulator)) "the library's emulator (its error in the bands)" else
    "the simulator"
  subtitle <- wrap_subtitle(c(
    "Black: field data (missing cells left out).",
    paste0("Blue: simulator", if (isTRUE(discrepancy)) " + discrepancy",
           " at the drawn runs (mean, ", format(100 * level), "% band). Grey: with fitted noise."),
    paste0("New settings (orange", if (lib_n_t(lib) > 1L || ncol(x_lib) > 1L) ", \"(new)\"",
           "): the drawn runs through ", route, ".")))
  p <- if (lib_n_t(lib) == 1L && ncol(x_lib) == 1L) {
    ppc_new_along_x(pred, names(x_lib), range(x_lib[[1]]))
  } else {
    ppc_new_panels(pred, lib)
  }
  p + ggplot2::labs(y = "Output", title = "Posterior predictive check and prediction",
                    subtitle = subtitle) +
    ggplot2::theme_bw()
}

# One output per setting, one x column `x_name`: the bands as ribbons over
# x, joined across library and new settings; the calibrated range `span`
# between dashed lines, outside which the prediction extrapolates.
ppc_new_along_x <- function(pred, x_name, span) {
  pred$position <- pred[[x_name]]
  pred <- pred[order(pred$position), ]
  ggplot2::ggplot(pred, ggplot2::aes(x = .data$position)) +
    ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$pred_lower, ymax = .data$pred_upper),
                         fill = "grey80") +
    ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lower, ymax = .data$upper),
                         fill = "steelblue", alpha = 0.5) +
    ggplot2::geom_line(ggplot2::aes(y = .data$mean), colour = "steelblue") +
    ggplot2::geom_vline(xintercept = span, linetype = "dashed", colour = "grey40") +
    ggplot2::geom_pointrange(data = pred[pred$new, ],
                             ggplot2::aes(y = .data$mean, ymin = .data$pred_lower,
                                          ymax = .data$pred_upper),
                             colour = "darkorange", size = 0.3) +
    ggplot2::geom_point(ggplot2::aes(y = .data$observed), colour = "black", shape = 4,
                        size = 2.5, na.rm = TRUE) +
    ggplot2::labs(x = x_name)
}

# One panel per setting (the library's first, then the new ones, "(new)"),
# against t; with one output per setting, against the settings' labels.
ppc_new_panels <- function(pred, lib) {
  x_names <- names(lib_x(lib))
  label <- do.call(paste, c(Map(function(n, v) paste(n, "=", format(v, digits = 4)),
                                x_names, pred[x_names]), sep = ", "))
  label <- ifelse(pred$new, paste(label, "(new)"), label)
  # one x column: the panels in its order, the new settings among the library's
  o <- if (length(x_names) == 1L) order(pred[[x_names]]) else seq_along(label)
  pred$setting <- factor(label, levels = unique(label[o]))
  colour <- ifelse(pred$new, "darkorange", "steelblue")
  if (lib_n_t(lib) == 1L) {
    return(ggplot2::ggplot(pred, ggplot2::aes(x = .data$setting)) +
      ggplot2::geom_linerange(ggplot2::aes(ymin = .data$pred_lower, ymax = .data$pred_upper),
                              colour = "grey60", linewidth = 2) +
      ggplot2::geom_pointrange(ggplot2::aes(y = .data$mean, ymin = .data$lower,
                                            ymax = .data$upper), colour = colour) +
      ggplot2::geom_point(ggplot2::aes(y = .data$observed), colour = "black", shape = 4,
                          size = 2.5, na.rm = TRUE) +
      setting_axis(nlevels(pred$setting)) + ggplot2::labs(x = "x setting"))
  }
  ggplot2::ggplot(pred, ggplot2::aes(x = .data$t)) +
    ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$pred_lower, ymax = .data$pred_upper),
                         fill = "grey80") +
    ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lower, ymax = .data$upper, fill = .data$new),
                         alpha = 0.5, show.legend = FALSE) +
    ggplot2::geom_line(ggplot2::aes(y = .data$mean, colour = .data$new), show.legend = FALSE) +
    ggplot2::scale_fill_manual(values = c(`FALSE` = "steelblue", `TRUE` = "darkorange")) +
    ggplot2::scale_colour_manual(values = c(`FALSE` = "steelblue", `TRUE` = "darkorange")) +
    ggplot2::geom_point(ggplot2::aes(y = .data$observed), size = 0.6, na.rm = TRUE) +
    ggplot2::facet_wrap(ggplot2::vars(.data$setting), scales = "free_y") +
    ggplot2::scale_x_continuous(n.breaks = 4, guide = ggplot2::guide_axis(check.overlap = TRUE)) +
    ggplot2::labs(x = "t")
}

# The library of what the ppc plot predicts from: a fit's, or a stream's.
predicted_library <- function(object) {
  if (inherits(object, "griddy_stream")) object$state$library else object$library
}
