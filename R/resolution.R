# Is the library fine and wide enough for this posterior? Griddy treats the
# library as the whole parameter space, so when the data pin theta down more
# tightly than the library's spacing, the posterior collapses onto a few runs
# and its intervals show the spacing, not the data's uncertainty (and miss a
# truth that lies between runs). The checks here work per parameter, on the
# marginal of the posterior over runs: how many distinct values carry it, and
# how much of it sits at the library's minimum or maximum.

# How many equal weights would carry the same mass as probabilities p
# (summing to 1): 1 / sum p^2, Kish's effective sample size. Every
# "effective runs" and "effective values" in griddy is this count.
effective_count <- function(p) 1 / sum(p^2)

# The fewest effective values (1 / sum m_v^2 over the marginal masses m_v of a
# parameter's distinct values) at which a marginal resolves its interval. For
# a Gaussian marginal of sd s on a grid of step h, m_v ~ h phi(v / s) / s, so
# sum m_v^2 ~ (h / s) int phi^2 = h / (2 sqrt(pi) s): effective values
# ~ 2 sqrt(pi) s / h ~ 3.5 s / h. Ten of them means h <~ s / 3, and a
# quantile of the discrete marginal (a grid value) then lies within one step,
# about a third of an sd, of the continuous one (in practice within little
# more than half a step; test-resolution.R checks this on grids of
# several steps).
resolution_min_values <- 10

# Share of the posterior on a parameter's minimum or maximum above which the
# truth may lie outside the library's range.
edge_mass_threshold <- 0.05

# "At the minimum" means within this share of the interval's width of it.
# On a grid whose posterior collapses onto the minimum that is the minimum
# alone; a scattered design (a Latin hypercube, an emulated library) has a
# single run at its minimum, which carries no mass however hard the
# posterior presses against the edge: there the band catches it. A
# posterior cut off at its mode by the range holds about 8% in the band,
# one whose 2.5% tail just reaches the edge about 1%, a flat one 5%.
edge_band_share <- 0.05

# Values closer than this fraction of a column's range count as the same
# value (and as the minimum or maximum): designs written to text files
# round-trip with such differences.
value_tolerance <- 1e-9

# Per parameter: the interval of the marginal posterior over the library's
# values, how many distinct values carry it, the mass at the column's minimum
# and maximum, and whether the column is constant. `p`: posterior probability
# of each run (sums to 1); `theta`: the runs' parameters (data.frame, one row
# per run).
#
# Only the runs with positive probability (`support`) are grouped and sorted:
# on 10^6 scattered runs a few dozen carry the whole posterior (the others'
# probabilities underflow to 0), and sorting all of them took 95% of
# calibrate(). The table is the same as over every run, with two exceptions
# that move a value by less than the tolerance: a group's value is the
# smallest value that carries mass, and values are merged along chains of
# near-equal values that carry mass (not through runs that carry none).
resolution_table <- function(p, theta, level = 0.95, min_values = resolution_min_values,
                             scattered = FALSE) {
  support <- which(p > 0)
  rows <- lapply(names(theta), function(j) {
    marginal_resolution(p[support], theta[[j]], support, level, min_values)
  })
  # one data.frame from the rows' columns (an rbind() of one-row
  # data.frames cost most of the table on a small problem)
  out <- columns_frame(c(list(parameter = names(theta)),
                         lapply(stats::setNames(nm = names(rows[[1]])), function(col) {
                           unlist(lapply(rows, `[[`, col), use.names = FALSE)
                         })))
  # from four parameters, or in a library grown by refine()'s proposals
  # (`scattered`), the posterior over runs as an importance sample
  # (resolution-runs.R): a parameter is limited while it is not resolved
  runs <- run_resolution(p, sum(!out$constant), scattered)
  out$effective_runs <- runs$effective_runs
  out$pareto_k <- runs$pareto_k
  out$limited <- out$limited | (!runs$resolved & !out$constant)
  attr(out, "runs") <- runs
  out
}

# A data.frame of equally long, named, plain columns, as data.frame() makes
# it, without its checks and conversions (which took most of a small fit's
# resolution table).
columns_frame <- function(cols) {
  structure(cols, class = "data.frame", row.names = c(NA_integer_, -length(cols[[1]])))
}

# One column of resolution_table(): `v` the column, `support` the runs with
# positive probability and `mass` their probabilities.
marginal_resolution <- function(mass, v, support, level, min_values) {
  span <- value_range_cpp(as.double(v))
  tol <- value_tolerance * (span[2] - span[1])
  vs <- v[support]
  o <- order(vs)
  group <- value_groups(vs, tol, o)
  # per group, in increasing order of value: its first value in sorted order,
  # and its mass (summed in run order)
  values <- vs[o][!duplicated(group[o])]
  # a group of one run has that run's mass (0 + m = m: the same double as
  # rowsum() gives); rowsum(), whose group names cost more than the rest on
  # 10^5 groups, sums only the groups of several runs, in run order as before
  group_mass <- numeric(length(values))
  single <- tabulate(group, length(values))[group] == 1L
  group_mass[group[single]] <- mass[single]
  if (!all(single)) {
    several <- group[!single]
    group_mass[sort(unique(several))] <- as.vector(rowsum(mass[!single], several))
  }
  tail <- (1 - level) / 2
  # the smallest value whose cumulative mass reaches each probability
  bounds <- unname(weighted_quantile(values, group_mass, c(tail, 1 - tail)))
  lower <- bounds[1]
  upper <- bounds[2]
  band <- max(tol, edge_band_share * (upper - lower))
  list(lower = lower, upper = upper, effective_values = effective_count(group_mass),
       distinct_in_interval = sum(values >= lower & values <= upper),
       limited = effective_count(group_mass) < min_values,
       mass_at_min = sum(mass[vs <= span[1] + band]),
       mass_at_max = sum(mass[vs >= span[2] - band]),
       constant = span[1] == span[2])
}

# Group ids (1, 2, ... in increasing order of value) that merge values closer
# than `tol` to the previous one.
value_groups <- function(v, tol, o = order(v)) {
  ids <- integer(length(v))
  # back to run order by the permutation itself (no second sort)
  ids[o] <- cumsum(c(TRUE, diff(v[o]) > tol))
  ids
}

# The resolution table of a fit, from its exact posterior over runs.
# new_griddy_fit() stores the table at the default level, which calibrate()'s
# warning and a default summary() read.
resolution_limited <- function(fit, level = 0.95) {
  if (level == 0.95 && !is.null(fit$resolution)) return(fit$resolution)
  resolution_table(exact_margins(fit)$run, lib_theta(fit$library), level,
                   scattered = has_proposal_rounds(fit$library))
}

# What summary() reports: the resolution table (exact posterior), the
# effective number of runs (exact and sampled), the total-variation distance
# between the sampled and the exact posterior over runs, and what Monte Carlo
# error alone would give at the draws' effective number (see convergence.R).
library_adequacy <- function(fit, level = 0.95) {
  exact <- exact_margins(fit)$run
  effective_draws <- stored_diagnostics(fit)$effective_draws
  list(parameters = resolution_limited(fit, level),
       effective_runs = effective_count(exact),
       effective_runs_sampled = effective_count(sampled_frequencies(fit$draws$run)$freq),
       tv_distance = run_tv_distance(fit$draws$run, exact),
       tv_reference = expected_tv(exact, effective_draws),
       effective_draws = effective_draws,
       emulation_error = emulation_error(fit))
}

# The leave-one-out error of the emulator that predicted the library's runs,
# near the posterior, over the noise sd: refine()'s when it predicted runs,
# else an emulated library's (NULL when every run was simulated).
emulation_error <- function(fit) {
  if (!is.null(fit$refinement$emulation_error)) return(fit$refinement$emulation_error)
  fit$emulation_error
}

# calibrate()'s warning. A constant column is left out: sim_library() has
# warned about it, and more runs cannot resolve it.
warn_resolution <- function(fit) {
  tab <- resolution_limited(fit)
  tab <- tab[tab$limited & !tab$constant, , drop = FALSE]
  if (nrow(tab) == 0L) {
    return(invisible(NULL))
  }
  runs <- run_resolution_reason(attr(resolution_limited(fit), "runs"))
  if (!is.null(runs)) {
    griddy_warn(
      "The posterior is limited by the library's resolution: it rests on ", runs,
      ", so its intervals show where the runs are, not the data's uncertainty, and may ",
      "miss the truth. Add runs where the posterior has its mass (see ?refine).",
      class = "resolution")
    return(invisible(NULL))
  }
  griddy_warn(
    "The posterior is limited by the library's resolution: ",
    paste0(tab$parameter, " (", format_values(tab$effective_values), " effective values)",
           collapse = ", "),
    if (nrow(tab) == 1L) " is" else " are", " carried by fewer than ", resolution_min_values,
    " effective library values, so the intervals show the library's spacing, not the data's ",
    "uncertainty, and may miss a truth between runs. Add runs where the posterior has ",
    "its mass (see ?refine).", class = "resolution")
}

format_values <- function(v) vapply(v, format, "", digits = 2, nsmall = 1, USE.NAMES = FALSE)

# summary()'s printed checks: one line for the runs, one per limited
# parameter and one per parameter with mass at the edge of its range.
# A total-variation distance to 2 significant digits, or "< 0.0001": on one
# run both distances are rounding noise (it printed 7.1e-289).
format_distance <- function(d) {
  if (is.finite(d) && d < 1e-4) "< 0.0001" else format(d, digits = 2)
}

format_adequacy <- function(adequacy) {
  tab <- adequacy$parameters
  lines <- c(
    paste0("Library: effective number of runs ", format(adequacy$effective_runs, digits = 3),
           " (sampled ", format(adequacy$effective_runs_sampled, digits = 3), ")."),
    paste0("Draws vs exact posterior over runs: total-variation distance ",
           format_distance(adequacy$tv_distance),
           if (!is.null(adequacy$tv_reference)) {
             paste0(" (Monte Carlo error alone: ", format_distance(adequacy$tv_reference),
                    " at ", format(round(adequacy$effective_draws)), " effective draws)")
           }, "."),
    if (!is.null(adequacy$emulation_error)) {
      paste0("Emulated runs: leave-one-out error near the posterior ",
             format(adequacy$emulation_error, digits = 2), " x the noise sd",
             if (adequacy$emulation_error > emulation_error_threshold) " (above 1: see ?refine)",
             "; it is in the likelihood.")
    })
  # a summary saved before 0.1.1.9000 counted the library's values instead
  constant <- if (is.null(tab$constant)) tab$library_values <= 1L else tab$constant
  lim <- tab$limited & !constant
  runs <- run_resolution_reason(attr(tab, "runs"))
  if (!is.null(runs)) {
    lines <- c(lines, paste0("Runs: the posterior rests on ", runs, "; see ?refine"))
    lim <- lim & tab$effective_values < resolution_min_values
  }
  c(lines,
    paste0(tab$parameter[constant], ": constant in the library, not calibrated.",
           recycle0 = TRUE),
    paste0(tab$parameter[lim], ": interval limited by the library's resolution (",
           format_values(tab$effective_values[lim]), " effective values; ",
           resolution_min_values, " needed); see ?refine", recycle0 = TRUE),
    format_edges(tab[!constant, , drop = FALSE]))
}

format_edges <- function(tab) {
  side <- function(mass, where) {
    hit <- mass > edge_mass_threshold
    percent <- vapply(100 * mass[hit], format, "", digits = 2)
    paste0(tab$parameter[hit], ": ", percent, "% of the posterior at the library's ", where,
           "; the truth may lie outside the library's range of ", tab$parameter[hit], ".",
           recycle0 = TRUE)
  }
  c(side(tab$mass_at_min, "minimum"), side(tab$mass_at_max, "maximum"))
}
