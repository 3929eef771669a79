# A refined library: a library (any backend) plus runs that refine() added
# where the posterior has its mass, round by round. It is an ordinary library
# (the interface of library.R), so calibrate(), posterior_exact(),
# predict() and refine() itself take it like any other, and saveRDS() keeps
# it.
#
# Two things set its runs apart from a plain library's, and both travel with
# it so that a later calibrate() on it gives the same posterior:
#
# * Prior weights. A library's uniform prior over runs is a uniform prior
#   over theta only while the runs fill the parameter box evenly. refine()
#   adds runs by rounds of Latin hypercubes in smaller boxes, so the design
#   density is a sum of uniform densities: N0 / vol(B0) over the base
#   library's box B0, plus n_r / vol(B_r) over each round's box B_r (or, in
#   four or more parameters, n_r times the density of the round's proposal,
#   a defensive uniform plus a t mixture: refine-proposal.R). Each run
#   is weighed by prior density / design density (the balance heuristic of
#   multiple importance sampling), which keeps the prior uniform over B0.
# * Emulation error. Runs predicted by an emulator rather than simulated
#   carry the emulator's error, delta ~ N(0, kappa_i V), with V = U diag(lambda)
#   U' the leading components of the emulator's leave-one-out residuals on the
#   library and kappa_i in [0, 1] the prediction's relative variance at run i
#   (0 at a simulated run). The likelihood's covariance becomes
#   tau^-1 R_g + kappa_i V, which with the plug-in noise variance s2 of the
#   round (the posterior mean of 1/tau when it was refined) is
#   tau^-1 (R_g + kappa_i V / s2): still conjugate in tau, so the engine is
#   unchanged. See emulated_quad_forms().

# `replaced` holds the runs whose predicted outputs a simulator replaced:
# their rows (of the whole library) and outputs. The design is unchanged
# (same theta), so are the prior weights; the runs lose their emulation
# error (an added run's kappa becomes 0).
new_refined_library <- function(base, theta, y, rounds, round_of, rel_var,
                                replaced = no_replaced(lib_n_out(base))) {
  structure(
    list(theta = theta, x = lib_x(base), t = lib_t(base), base = base,
         added = list(y = y, round = round_of, rel_var = rel_var), rounds = rounds,
         replaced = replaced),
    class = "refined_library"
  )
}

no_replaced <- function(n_out) list(rows = integer(), y = matrix(0, 0, n_out))

#' @export
print.refined_library <- function(x, ...) {
  n0 <- lib_n_runs(x$base)
  sources <- vapply(x$rounds, `[[`, "", "source")
  runs <- vapply(x$rounds, `[[`, numeric(1), "n")
  cli::cat_line("<refined_library> ", lib_n_runs(x), " runs of ", ncol(x$theta),
                " parameter(s): ", n0, " of the base library (", class(x$base)[1], ") + ",
                lib_n_runs(x) - n0, " added in ", length(x$rounds), " round(s) (",
                sum(runs[sources == "simulator"]), " simulated, ",
                sum(runs[sources == "emulator"]), " predicted)",
                if (length(x$replaced$rows) > 0L) paste0("; ", length(x$replaced$rows),
                                                         " predicted run(s) since simulated"))
  ranges <- vapply(x$theta, function(v) {
    paste0(format(min(v), digits = 4), " to ", format(max(v), digits = 4))
  }, "")
  cli::cat_line("  theta: ", paste0(names(ranges), " [", ranges, "]", collapse = ", "))
  cli::cat_line("  outputs: ", lib_n_out(x), " per run; prior weights correct for the ",
                "added runs' density (see ?refine)")
  invisible(x)
}

# Add runs to a library (refined or not). `round` is list(lower, upper, n,
# source, error), the round's box and error model (NULL for simulated runs).
add_runs <- function(library, theta_new, y_new, round, rel_var = NULL) {
  if (!inherits(library, "refined_library")) {
    library <- new_refined_library(library, lib_theta(library), matrix(0, 0, lib_n_out(library)),
                                   rounds = list(), round_of = integer(), rel_var = numeric())
  }
  if (is.null(round)) return(library)
  if (is.null(rel_var)) rel_var <- numeric(nrow(theta_new))
  r <- length(library$rounds) + 1L
  out <- new_refined_library(
    library$base, rbind(library$theta, theta_new), rbind(library$added$y, y_new),
    rounds = c(library$rounds, list(round)),
    round_of = c(library$added$round, rep(r, nrow(theta_new))),
    rel_var = c(library$added$rel_var, rel_var), replaced = library$replaced)
  # the design density at every run, kept up to date round by round: the
  # old runs gain the new round's density, the new runs get all rounds'
  # (recomputing every round's density at every run each round cost
  # refine() most of its time in many parameters)
  before <- if (is.null(library$density)) design_density(library, library$theta) else
    library$density
  out$density <- c(before + round_density(round, library$theta, library_box(library$base)),
                   design_density(out, theta_new))
  out
}

# Replace predicted runs `rows` (of the whole library) by the simulator's
# outputs `y` at the same theta.
replace_runs <- function(library, rows, y) {
  if (!inherits(library, "refined_library")) library <- add_runs(library, NULL, NULL, NULL)
  n0 <- lib_n_runs(library$base)
  added <- rows > n0
  library$added$y[rows[added] - n0, ] <- y[added, , drop = FALSE]
  library$added$rel_var[rows[added] - n0] <- 0
  keep <- !library$replaced$rows %in% rows
  library$replaced <- list(rows = c(library$replaced$rows[keep], rows),
                           y = rbind(library$replaced$y[keep, , drop = FALSE], y))
  library
}

# ---- the interface ----------------------------------------------------------

#' @exportS3Method
lib_outputs.refined_library <- function(library, rows = NULL) {
  rows <- lib_check_rows(library, rows)
  n0 <- lib_n_runs(library$base)
  out <- matrix(0, length(rows), lib_n_out(library))
  in_base <- rows <= n0
  if (any(in_base)) out[in_base, ] <- lib_outputs(library$base, rows[in_base])
  if (any(!in_base)) out[!in_base, ] <- library$added$y[rows[!in_base] - n0, , drop = FALSE]
  hit <- match(rows, library$replaced$rows)
  if (any(!is.na(hit))) out[!is.na(hit), ] <- library$replaced$y[hit[!is.na(hit)], , drop = FALSE]
  out
}

#' @exportS3Method
lib_on_disk.refined_library <- function(library) lib_on_disk(library$base)

# The forms of the base runs, then of the added ones (misfit_parts()): C
# with the added runs' extra log-determinant (see emulated_quad_forms()),
# which misfit_table() folds into C, and what the base library found beside
# its C (an emulated base's error and plug-in).
#' @exportS3Method
lib_quad_forms.refined_library <- function(library, y_field, setup) {
  base <- misfit_parts(lib_quad_forms(library$base, y_field, setup))
  added <- added_quad_forms(library, seq_len(nrow(library$added$y)), y_field, setup)
  base_extra <- base$extra_logdet
  if (is.null(base_extra)) base_extra <- matrix(0, nrow(base$C), ncol(base$C))
  forms <- list(C = rbind(base$C, added$C), extra_logdet = rbind(base_extra, added$extra_logdet))
  forms <- replaced_forms(library, seq_len(nrow(forms$C)), forms, y_field, setup)
  forms$emulation_error <- base$emulation_error
  forms$plug_in <- base$plug_in
  forms
}

# The forms of rows `rows` (list(C, extra_logdet)) made plain where the run
# was replaced by a simulated one (an added run's are already: its kappa is
# 0).
replaced_forms <- function(library, rows, forms, y_field, setup) {
  hit <- match(rows, library$replaced$rows)
  at <- which(!is.na(hit) & rows <= lib_n_runs(library$base))
  if (length(at) == 0L) return(forms)
  forms$C[at, ] <- plain_quad_forms(library$replaced$y[hit[at], , drop = FALSE], y_field, setup)
  forms$extra_logdet[at, ] <- 0
  forms
}

#' @exportS3Method
lib_run_quad_forms.refined_library <- function(library, rows, y_field, setup) {
  n0 <- lib_n_runs(library$base)
  C <- matrix(0, length(rows), n_grid_points(setup))
  extra <- C
  in_base <- rows <= n0
  # a replaced base run's forms are plain (replaced_forms())
  from_base <- in_base & !rows %in% library$replaced$rows
  if (any(from_base)) {
    # a base library's forms may depend on all its runs (an emulated one's
    # plug-in noise variance)
    base <- misfit_parts(lib_quad_forms(library$base, y_field, setup))
    C[from_base, ] <- base$C[rows[from_base], , drop = FALSE]
    if (!is.null(base$extra_logdet)) {
      extra[from_base, ] <- base$extra_logdet[rows[from_base], , drop = FALSE]
    }
  }
  if (any(!in_base)) {
    added <- added_quad_forms(library, rows[!in_base] - n0, y_field, setup)
    C[!in_base, ] <- added$C
    extra[!in_base, ] <- added$extra_logdet
  }
  replaced_forms(library, rows, list(C = C, extra_logdet = extra), y_field, setup)
}

#' @exportS3Method
lib_base.refined_library <- function(library) library$base

#' @exportS3Method
lib_rounds.refined_library <- function(library) library$rounds

#' @exportS3Method
lib_predicted.refined_library <- function(library) {
  emulated_round <- vapply(library$rounds, function(r) !is.null(r$error), logical(1))
  predicted <- c(lib_predicted(library$base), emulated_round[library$added$round])
  predicted[library$replaced$rows] <- FALSE
  predicted
}

#' @exportS3Method
lib_simulated.refined_library <- function(library) {
  rows <- which(!lib_predicted(library))
  if (length(rows) == 0L) return(NULL)
  sim_library(lib_theta(library)[rows, , drop = FALSE], lib_outputs(library, rows),
              x = lib_x(library), t = lib_t(library))
}

# An emulated base library predicts with its own emulator of its design
# runs; otherwise the emulator learns from the simulated runs.
#' @exportS3Method
lib_emulator.refined_library <- function(library, region, ...) {
  if (all(lib_predicted(library$base))) return(lib_emulator(library$base, region, ...))
  lib_emulator(lib_simulated(library), region, ...)
}

#' @exportS3Method
lib_noise_var.refined_library <- function(library) {
  rounds <- Filter(function(r) !is.null(r$error), library$rounds)
  c(unlist(lapply(rounds, function(r) r$error$noise_var)), lib_noise_var(library$base))
}

#' @exportS3Method
lib_prediction_errors.refined_library <- function(library) {
  list(n_base = lib_n_runs(library$base), base = lib_prediction_errors(library$base)$base,
       round = library$added$round, kappa = library$added$rel_var,
       errors = lapply(library$rounds, `[[`, "error"), replaced = library$replaced$rows)
}

# An emulated base library's plug-in, found by its misfit table.
#' @exportS3Method
lib_with_plug_in.refined_library <- function(library, plug_in) {
  library$base <- lib_with_plug_in(library$base, plug_in)
  library
}

#' @exportS3Method
lib_with_noise_var.refined_library <- function(library, noise_var, y_field) {
  library$base <- lib_with_noise_var(library$base, noise_var, y_field)
  for (r in seq_along(library$rounds)) {
    if (!is.null(library$rounds[[r]]$error)) library$rounds[[r]]$error$noise_var <- noise_var
  }
  library
}

# The forms of added runs `which` (positions among the added runs): plain
# quadratic forms for simulated runs, the emulation-error forms for
# predicted ones, as list(C, extra_logdet) (0 for simulated runs).
added_quad_forms <- function(library, which, y_field, setup) {
  y <- library$added$y[which, , drop = FALSE]
  round <- library$added$round[which]
  C <- matrix(0, length(which), n_grid_points(setup))
  extra <- C
  # a run with a prediction error has only its emulated forms (the plain
  # ones, half the cost under a discrepancy, would be overwritten)
  plain <- vapply(round, function(r) is.null(library$rounds[[r]]$error), logical(1))
  if (any(plain)) C[plain, ] <- plain_quad_forms(y[plain, , drop = FALSE], y_field, setup)
  for (r in unique(round[!plain])) {
    err <- library$rounds[[r]]$error
    rows <- which(round == r)
    em <- emulated_quad_forms(y[rows, , drop = FALSE], y_field, setup, err,
                              library$added$rel_var[which][rows], lib_n_x(library),
                              lib_n_t(library))
    C[rows, ] <- em$C
    extra[rows, ] <- em$logdet
  }
  list(C = C, extra_logdet = extra)
}

#' @exportS3Method
lib_check_integrity.refined_library <- function(library) {
  lib_check_integrity(library$base)
  n_added <- nrow(library$added$y)
  if (!is.matrix(library$added$y) || ncol(library$added$y) != lib_n_out(library$base) ||
      length(library$added$round) != n_added || length(library$added$rel_var) != n_added) {
    griddy_abort("The refined library has been edited: its added runs do not fit together; ",
                 "refine the fit again.", class = "shape")
  }
  check_library_parts(library, lib_n_runs(library$base) + n_added, lib_n_out(library$base),
                      "refined library", fix = "Refine the fit again.")
  if (!all(is.finite(library$added$y))) {
    griddy_abort("The refined library has been edited: its added outputs are not all ",
                 "finite.", class = "shape")
  }
  rep <- library$replaced
  if (!is.list(rep) || !is.matrix(rep$y) || nrow(rep$y) != length(rep$rows) ||
      ncol(rep$y) != lib_n_out(library$base) || !all(is.finite(rep$y)) ||
      any(!rep$rows %in% seq_len(lib_n_runs(library)))) {
    griddy_abort("The refined library has been edited: its replaced runs do not fit ",
                 "together; refine the fit again.", class = "shape")
  }
  invisible(library)
}

# The log prior weight of each run: prior density over design density (see
# the top of this file), normalised. A plain library's runs are equally
# weighted.
lib_log_prior <- function(library) UseMethod("lib_log_prior")

#' @exportS3Method
lib_log_prior.default <- function(library) {
  rep(-log(lib_n_runs(library)), lib_n_runs(library))
}

#' @exportS3Method
lib_log_prior.refined_library <- function(library) {
  density <- if (is.null(library$density)) design_density(library, library$theta) else
    library$density
  normalise_log_prob(-log(density))
}

# The design density of a refined library at the rows of `theta`: the base
# library's runs spread evenly over its box, plus each round's runs over its
# box, or by its proposal's density (refine-proposal.R, four or more
# parameters). Constant columns take no part in the volumes.
design_density <- function(library, theta) {
  theta <- as.matrix(theta)
  box0 <- library_box(library$base)
  density <- lib_n_runs(library$base) / box_volume(box0) * in_box(theta, box0)
  for (round in library$rounds) density <- density + round_density(round, theta, box0)
  density
}

# One round's share of the design density at the rows of `theta`.
round_density <- function(round, theta, box0) {
  if (is.null(round$proposal)) {
    round$n / box_volume(round$box, box0) * in_box(as.matrix(theta), round$box)
  } else {
    round$n * proposal_density(round$proposal, theta)
  }
}

# The box spanned by a library's runs: a 2-row matrix (lower, upper) with one
# column per parameter.
library_box <- function(library) {
  theta <- as.matrix(lib_theta(library))
  rbind(apply(theta, 2, min), apply(theta, 2, max))
}

box_volume <- function(box, reference = box) {
  varies <- reference[2, ] > reference[1, ]
  prod(box[2, varies] - box[1, varies])
}

in_box <- function(theta, box) {
  tol <- 1e-12 * pmax(abs(box[2, ]), abs(box[1, ]), 1)
  above <- sweep(theta, 2, box[1, ] - tol, ">=")
  below <- sweep(theta, 2, box[2, ] + tol, "<=")
  rowSums(above & below) == ncol(theta)
}
