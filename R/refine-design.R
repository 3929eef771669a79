# Where refine()'s new runs go: the box of a round around the posterior,
# a Latin hypercube in it (or, in four or more parameters, a proposal fitted
# to the posterior: refine-proposal.R), and which predicted runs a
# simulator replaces.

# The new runs of a round of n: list(theta, round = the round's design as
# the refined library keeps it, box or proposal). The box's Latin hypercube
# up to three parameters, the proposal from four (see uses_proposal()), and
# in fewer when the posterior has separated modes: a box spanning two modes
# spreads its runs over the empty space between them, and the rounds after
# zoom in on whichever mode one run happened to land nearest (issue 24: in
# an aliased two-parameter oscillator, three of six refinements lost the
# mode and one kept only the wrong one, all "resolved").
round_design <- function(state, n) {
  library <- state$problem$library
  names <- names(lib_theta(library))
  # a base posterior on few runs first gets a search round (refine-modes.R)
  search <- mode_search_proposal(state)
  if (!is.null(search)) {
    return(list(theta = draw_proposal(n, search, names), round = list(box = NULL, proposal = search)))
  }
  last <- last_proposal(library)
  follows <- uses_proposal(library) || (!is.null(last) && proposals_follow(last))
  # below four parameters the fit only decides, so it leaves the random
  # stream as it was: a unimodal posterior gets the same boxes as before
  # (only on the base library, spread evenly, or on the library a search
  # round has just grown, half of it spread evenly: once boxes have crowded
  # runs into one region, tempering shows their crowd and the runs outside
  # as two clusters that are not two modes). After a search that seeded
  # one maximum, boxes unless the runs it drew show separated modes:
  # proposals there cost the one-parameter toy of test-refine.R more than
  # 600 runs where boxes resolve it in 200-400
  first <- (length(lib_rounds(library)) == 0L && lib_n_runs(library) >= proposal_min_runs) ||
    after_search(library)
  proposal <- if (follows) fit_proposal(state) else if (first) {
    withr::with_preserve_seed(fit_proposal(state))
  }
  if (!is.null(proposal) && (follows || separated_modes(proposal))) {
    return(list(theta = draw_proposal(n, proposal, names),
                round = list(box = NULL, proposal = proposal)))
  }
  box <- refine_box(state)
  list(theta = latin_hypercube(n, box, names), round = list(box = box, proposal = NULL))
}

# Only a search round has grown the library (refine-modes.R).
after_search <- function(library) {
  rounds <- lib_rounds(library)
  length(rounds) == 1L && !is.null(rounds[[1]]$proposal) && is_search_proposal(rounds[[1]]$proposal)
}

# The box of the marginal posteriors' central 99%, widened on each side by
# the local spacing around the most probable run or a quarter of its width,
# whichever is larger, inside the base library's range. (Central quantiles,
# not the runs holding 99.9% of the mass: with few data the posterior's
# tails are long, and a box around all of them spreads each round's runs
# over the whole range. The tails keep the runs of earlier rounds.) A box only as wide
# as the posterior's runs would cut off what the last round's runs could not
# reach, and keep cutting it off; widening by a share of the width lets a
# truncated posterior grow its box by half each round until it is whole.
box_margin <- 0.25

refine_box <- function(state) {
  library <- state$problem$library
  theta <- as.matrix(lib_theta(library))
  range0 <- library_box(lib_base(library))
  bounds <- apply(theta, 2, weighted_quantile, w = state$p, probs = c(0.005, 0.995))
  lower <- bounds[1, ]
  upper <- bounds[2, ]
  margin <- pmax(local_spacing(theta, which.max(state$p), range0), box_margin * (upper - lower))
  # a posterior cut off by the last round's box reaches for a whole box
  # width beyond it, so a box that missed the truth finds it in a few rounds
  cut <- truncated_sides(state)
  if (any(cut)) {
    last <- last_box(library)
    width <- last[2, ] - last[1, ]
    lower[cut[1, ]] <- pmin(lower, last[1, ] - width)[cut[1, ]]
    upper[cut[2, ]] <- pmax(upper, last[2, ] + width)[cut[2, ]]
  }
  rbind(pmax(lower - margin, range0[1, ]), pmin(upper + margin, range0[2, ]))
}

# Sides (rows lower, upper; one column per parameter) on which the
# posterior's 95% interval reaches the edge band of the last round's box
# while the box stops short of the library's range: there the dense runs
# end, and the posterior is cut off by them rather than by the data.
truncated_sides <- function(state) {
  library <- state$problem$library
  p <- ncol(lib_theta(library))
  last <- last_box(library)
  if (is.null(last)) return(matrix(FALSE, 2, p))
  range0 <- library_box(lib_base(library))
  tab <- state$table
  # within a tenth of the box, and within an eighth of the interval's width:
  # a box reaching a whole width beyond one side may end a few interval
  # widths past the other, which is not a cut (the margin, at least a
  # quarter of the width, keeps an interior posterior further away)
  band <- pmin(edge_band * (last[2, ] - last[1, ]), box_margin / 2 * (tab$upper - tab$lower))
  rbind(tab$lower <= last[1, ] + band & last[1, ] > range0[1, ] & band > 0,
        tab$upper >= last[2, ] - band & last[2, ] < range0[2, ] & band > 0)
}

edge_band <- 0.1

last_box <- function(library) {
  rounds <- lib_rounds(library)
  if (length(rounds) == 0L) return(NULL)
  rounds[[length(rounds)]]$box
}

# The library's spacing around run `centre`, per parameter: the spread of
# the 2p runs nearest it (distances on columns scaled by the library's
# range), the typical gap of a scattered design; and at least the gap to the
# next distinct value of the column on either side, one step of a grid even
# when the nearest runs all lie along other axes.
local_spacing <- function(theta, centre, range0) {
  width <- range0[2, ] - range0[1, ]
  varies <- width > 0
  scaled <- sweep(theta[, varies, drop = FALSE], 2, width[varies], "/")
  d2 <- colSums((t(scaled) - scaled[centre, ])^2)
  near <- order(d2)[seq_len(min(2L * sum(varies) + 1L, nrow(theta)))]
  spacing <- numeric(ncol(theta))
  spacing[varies] <- apply(abs(sweep(theta[near, varies, drop = FALSE], 2,
                                     theta[centre, varies], "-")), 2, max)
  for (j in which(varies)) {
    gaps <- abs(unique(theta[, j]) - theta[centre, j])
    spacing[j] <- max(spacing[j], min(gaps[gaps > 1e-9 * width[j]]))
  }
  spacing
}

box_inside <- function(box, region) {
  all(box[1, ] >= region[1, ]) && all(box[2, ] <= region[2, ])
}

# n runs in `box` by a Latin hypercube (one run in each of n equal slices of
# every parameter, at a uniform place in its slice), from R's random stream.
latin_hypercube <- function(n, box, names) {
  u <- vapply(seq_len(ncol(box)), function(j) (sample.int(n) - stats::runif(n)) / n,
              numeric(n))
  u <- matrix(u, n, ncol(box))
  theta <- sweep(sweep(u, 2, box[2, ] - box[1, ], "*"), 2, box[1, ], "+")
  stats::setNames(as.data.frame(theta), names)
}


# ---- predicted runs a simulator replaces -------------------------------------

# With a simulator, predicted runs that hold more than this share of the
# posterior are simulated (at the same theta) before resolution is judged:
# then it is judged on simulated runs.
predicted_tol <- 0.01

predicted_mass <- function(state) {
  sum(state$p[lib_predicted(state$problem$library)])
}

# The predicted runs to simulate in a round of at most n runs: the most
# probable first, until they hold all but `predicted_tol` of the
# predicted runs' posterior mass.
runs_to_replace <- function(state, n) {
  predicted <- which(lib_predicted(state$problem$library))
  mass <- state$p[predicted]
  ord <- order(mass, decreasing = TRUE)
  need <- which(cumsum(mass[ord]) >= sum(mass) - predicted_tol)[1]
  predicted[ord[seq_len(min(n, need))]]
}
