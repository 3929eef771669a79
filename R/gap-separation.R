# WHERE A CANDIDATE PARTS FROM THE PARAMETER THAT ABSORBS IT: per x setting,
# how much of the candidate's effect the parameter's effect leaves
# unexplained. See ?diagnose_gap (`separation`) and design_sentence().

# The candidate's effect d_c (its run at strength `pair[1]` minus its
# zero-strength run `pair[2]`, which is the base model) against the
# parameter's effect d_p (the base run `imitator$j` that imitates the first,
# found by the confounding screen, minus that same zero-strength run: the
# output change of shifting theta, mostly `p`, by the amount that absorbs the
# effect), on the simulator's outputs (divided by the cells' relative sd
# where given). As in the screen, the imitation is a multiple of d_p plus a
# local linear correction (the differences of the base runs `imitator$nb`
# nearest run j in theta), fitted over every setting at once, so that the
# library's spacing is not read as a difference between the two effects.
# Per setting, `unexplained` is |d_c - imitation| over the larger of |d_c|
# and |imitation| there (0: the shift imitates the effect at that setting;
# 1 or more: it does not), and `ratio` is that setting's own best multiple
# of d_p over the multiple fitted to all settings (its drift across x says
# where the two part further). NULL with fewer than two x settings or no
# shift.
effect_separation <- function(ctx, base_Y, cand, pair, imitator, p, effect) {
  if (ctx$n_x < 2L) return(NULL)
  out <- lib_outputs(cand, pair)
  w <- if (is.null(ctx$sd)) 1 else 1 / ifelse(is.finite(ctx$sd) & ctx$sd > 0, ctx$sd,
                                                  stats::median(ctx$sd, na.rm = TRUE))
  d_c <- (out[1, ] - out[2, ]) * w
  d_p <- (base_Y[imitator$j, ] - out[2, ]) * w
  if (anyNA(d_p) || sum(d_p^2) == 0) return(NULL)
  local <- t(sweep(base_Y[imitator$nb, , drop = FALSE], 2, base_Y[imitator$j, ], "-")) * w
  imitation <- d_c - stats::lm.fit(cbind(d_p, local), d_c)$residuals
  beta <- sum(d_c * d_p) / sum(d_p^2)
  setting <- rep(seq_len(ctx$n_x), each = ctx$n_t)
  norm_by <- function(v) sqrt(as.vector(rowsum(v^2, setting)))
  size_c <- norm_by(d_c)
  ratio <- as.vector(rowsum(d_c * d_p, setting)) / as.vector(rowsum(d_p^2, setting)) / beta
  tab <- data.frame(effect = effect, absorbed_by = p, setting = seq_len(ctx$n_x),
                    effect_size = size_c,
                    unexplained = norm_by(d_c - imitation) / pmax(size_c, norm_by(imitation)),
                    ratio = ifelse(is.finite(ratio), ratio, NA_real_),
                    stringsAsFactors = FALSE)
  if (!is.null(ctx$x)) tab <- cbind(tab[1:3], ctx$x, tab[-(1:3)])
  tab
}

# The design advice for one confounded candidate from its rows of the
# separation table `sep`: where across x it and the absorbing parameter act
# most alike and where least, and where a measurement would separate them.
# NULL (the generic advice applies) with fewer than two settings, or when
# the parameter imitates the effect alike at every setting (the unexplained
# share nowhere 1% and nowhere 1.5 times its smallest value).
design_sentence <- function(sep, x) {
  if (is.null(sep) || nrow(sep) < 2L || anyNA(sep$unexplained)) return(NULL)
  u <- sep$unexplained
  lo <- which.min(u)
  hi <- which.max(u)
  if (u[hi] < 0.01 || u[hi] < 1.5 * u[lo]) return(NULL)
  lab <- gap_x_labels(list(x = x))
  lab <- if (identical(lab, as.character(seq_along(lab)))) paste("x setting", sep$setting) else
    lab[sep$setting]
  paste0("'", sep$effect[1], "' imitates a shift of ", sep$absorbed_by[1], " most closely at ",
         lab[lo], " (", format_shrink(u[lo]), " of its effect unexplained) and least at ", lab[hi],
         " (", format_shrink(u[hi]), "): measure ", beyond_phrase(sep, x, hi, lab[hi]),
         " to separate them.")
}

# Where to measure: at the setting that separates best, and beyond it when it
# is an end of a single numeric control setting and the ratio drifts
# monotonically towards it (the two effects part further past that end).
beyond_phrase <- function(sep, x, hi, label) {
  if (is.null(x) || ncol(x) != 1L || !is.numeric(x[[1]])) return(paste0("near ", label))
  v <- x[[1]][sep$setting]
  o <- order(v)
  drift <- diff(sep$ratio[o])
  monotone <- !anyNA(drift) && (all(drift > 0) || all(drift < 0))
  end <- if (v[hi] == max(v)) "above" else if (v[hi] == min(v)) "below" else ""
  if (!monotone || end == "") return(paste0("near ", label))
  paste0("at ", label, " or ", end)
}
