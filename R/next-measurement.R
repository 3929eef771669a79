#' Where to measure next
#'
#' Ranks candidate measurements (an x setting of the library and an output
#' coordinate t) by the information a measurement there is expected to bring
#' about the unknowns: the mutual information, in nats, between the new
#' measurement and the (library run, correlation grid point) of the exact
#' posterior, and for [stream_models()] the model too. The setting where the
#' runs (or the models) that the data so far leave in play disagree most,
#' relative to the noise, comes first; a setting where every run gives the
#' same output brings (almost) nothing.
#'
#' **What is computed.** Given the data so far, the posterior is a mixture
#' over components \eqn{k} = (run \eqn{i}, grid point \eqn{g}\[, model
#' \eqn{M}\]) with exact weights \eqn{w_k} ([posterior_exact()]). Given
#' \eqn{k}, with \eqn{\tau} integrated out under its Gamma posterior, a new
#' measurement at cell \eqn{c} is Student-t with \eqn{2a + n} degrees of
#' freedom (\eqn{a} the prior shape, \eqn{n} the measurements so far in the
#' cell's noise group), location the run's output at \eqn{c} and squared
#' scale \eqn{(b + C_{ig}/2) / (a + n/2)} (\eqn{C_{ig}} the run's quadratic
#' form in that group): the exact conditional predictive. Under an AR(1)
#' correlation over t (a stream's `rho_t`), the location adds the
#' conditional mean given the run's residuals at the nearest measured
#' coordinates before and after \eqn{c} at that setting, and the scale
#' shrinks by the conditional variance (the AR(1) is Markov, so these
#' neighbours are all that matter). The gain is
#' \deqn{I = H\left(\sum_k w_k p_k\right) - \sum_k w_k H(p_k),}
#' and `gain_model` the same with the models' predictive mixtures as the
#' components. The models weigh in with their probabilities as the next
#' update takes them (flattened by `forgetting`, see [stream_models()]).
#' \eqn{\tau} is a nuisance here: the information about it alone is not
#' counted.
#'
#' **How.** The component entropies are closed-form. The mixture's is
#' \eqn{\sum_j w_j [H(p_j) + KL(p_j \| p)]}, each Kullback-Leibler term by
#' 32-point Gauss-Legendre quadrature over the component's quantiles (its
#' integrand, the log ratio of a component to the mixture, is bounded and
#' tends to constants in the tails). Before that, each model's components
#' below the last \eqn{10^{-4}} of its mass are dropped: that changes the
#' exact gain by at most \eqn{h(\epsilon) + \epsilon \max(I, \log n_D)}
#' nats (\eqn{\epsilon
#' \le 10^{-4}} the mass dropped, \eqn{h} the binary entropy, \eqn{n_D} the
#' components dropped, \eqn{I} the gain), under 0.003 nats up to \eqn{10^8}
#' components, and `gain_model` by at most \eqn{h(\epsilon) + \epsilon
#' \max(I, \log M)} for \eqn{M} models. Then components whose locations lie
#' within a quarter of their scale (and whose scales agree to 5%) are merged
#' into one with the same weight, mean and variance, a merged component
#' keeping to one model (so one merge serves the mixture and each model's
#' part); if more than 64 per model remain, the components are summed into a
#' grid of at most 2^16 such bins, and the bins widen over those sums until
#' 64 per model remain (the answer is then an approximation, from coarser
#' components, which loses some of the information that separates close
#' runs). Against adaptive quadrature the mixture entropy agrees to about
#' 10^-3 nats for a few components; for a posterior spread over 10^5 runs
#' after two measurements the gain of one candidate checked was 0.01 nats
#' above the unmerged mixture's (bench/README.md). Numerical noise
#' below zero is returned as 0.
#'
#' **Scope.** Candidates are cells the library has (its x settings and t);
#' a setting without runs is an error (class `griddy_error_new_setting`).
#' For a [calibrate()] fit, grid points with a correlation (`rho_x` or
#' `rho_t` other than 0), a discrepancy, noise groups, relative `sd` or
#' emulated runs are not handled (class `griddy_error_unsupported`): give
#' the same data to a [griddy_stream()], which takes `rho_t` and noise
#' groups. Under an AR(1) correlation a cell measured already cannot be
#' measured again (the stream refuses it), so it is an error here too. With
#' the vague default prior, a noise group without a measurement has no
#' proper predictive (its degrees of freedom are \eqn{2a \approx 0}): take a
#' measurement first, or give the stream a proper prior (shape at least
#' 1/2).
#'
#' @param object A [griddy_stream()], a [stream_models()], or a
#'   [calibrate()] fit (see Scope).
#' @param candidates A data.frame of candidate measurements, one per row:
#'   the library's x columns (none when it has a single setting) and `t`
#'   (which may be left out when the library has a single output
#'   coordinate). `NULL` (the default): every cell of the library.
#' @param about What the information is about when ranking: `"all"` (the
#'   runs, grid points and models) or `"model"` (the model indicator alone;
#'   [stream_models()] only).
#' @return A data.frame, best candidate first: the candidate's row in
#'   `candidates` (`candidate`), its x columns and `t`, `gain` (expected
#'   information about everything unknown, nats) and, for [stream_models()],
#'   `gain_model` (about the model alone). It is sorted by `gain`, or by
#'   `gain_model` under `about = "model"`.
#' @seealso [griddy_stream()], [stream_models()], [posterior_exact()]
#' @references Lindley, D. V. (1956). On a measure of the information
#'   provided by an experiment. *Annals of Mathematical Statistics* 27(4),
#'   986-1005.
#' @examples
#' ex <- griddy_example()
#' s <- update(griddy_stream(ex$library), y = ex$field$y[1, 1:2],
#'             x = ex$field$x[1, , drop = FALSE], t = ex$library$t[1:2])
#' head(next_measurement(s), 3)
#' # which measurement best tells two models apart
#' rival <- sim_library(ex$library$theta, 0.9 * ex$library$y, x = ex$library$x,
#'                      t = ex$library$t)
#' m <- stream_models(spring = griddy_stream(ex$library, prior = list(shape = 1, rate = 1)),
#'                    damped = griddy_stream(rival, prior = list(shape = 1, rate = 1)))
#' head(next_measurement(m, about = "model"), 3)
#' @export
next_measurement <- function(object, candidates = NULL, about = c("all", "model")) {
  about <- match.arg(about)
  models <- if (inherits(object, "griddy_stream_models")) {
    object$state$streams
  } else if (inherits(object, c("griddy_stream", "griddy_fit"))) {
    list(object)
  } else {
    griddy_abort("`object` must be a griddy_stream, a stream_models() or a calibrate() fit; ",
                 "received ", class(object)[1], ".")
  }
  if (about == "model" && length(models) < 2L) {
    griddy_abort("`about = \"model\"` needs a stream_models(): one model leaves nothing to ",
                 "tell apart.")
  }
  if (length(models) > 1L) assert_streams_in_step(object$state)
  # the models' probabilities before the next measurement: flattened by the
  # forgetting exponent, as update() does before weighing it
  model_prob <- if (length(models) > 1L) {
    exp(normalise_log_prob(object$state$forgetting * object$state$log_prob))
  } else {
    1
  }
  first <- model_library(models[[1]])
  cand <- candidate_cells(first, candidates)
  if (is.null(candidates)) cand <- drop_unmeasurable(cand, models)
  parts <- Map(function(mod, p) {
    model_components(mod, p, candidate_cells(model_library(mod), cand$table)$column)
  }, models, model_prob)
  keep <- prune_components(lapply(parts, `[[`, "w"))
  parts <- Map(function(part, k) part$subset(k), parts, keep)
  rule <- legendre_rule()
  gains <- next_gains_cpp(lapply(parts, `[[`, "cpp"), length(cand$column), rule$u,
                          rule$weight, 64L)
  out <- cbind(data.frame(candidate = cand$row), cand$table)
  out$gain <- gains[1, ]
  if (length(models) > 1L) out$gain_model <- gains[2, ]
  key <- if (about == "model") out$gain_model else out$gain
  out <- out[order(-key, out$candidate), , drop = FALSE]
  rownames(out) <- NULL
  out
}

model_library <- function(object) {
  if (inherits(object, "griddy_fit")) object$library else object$state$library
}

# The library output column (blocks of n_t by x setting) of each candidate,
# and the candidates as a table (x columns and t).
candidate_cells <- function(lib, candidates) {
  x_lib <- lib_x(lib)
  t_lib <- lib_t(lib)
  n_t <- length(t_lib)
  if (is.null(candidates)) {
    candidates <- setting_cells(lib, seq_len(lib_n_x(lib)))[c(names(x_lib), "t")]
  }
  if (is.data.frame(candidates)) rownames(candidates) <- NULL
  if (!is.data.frame(candidates) || nrow(candidates) < 1L) {
    griddy_abort("`candidates` must be NULL or a data.frame with one row per candidate; ",
                 "received ", class(candidates)[1],
                 if (is.data.frame(candidates)) " with no rows", ".")
  }
  if (is.null(candidates$t)) {
    if (n_t > 1L) {
      griddy_abort("`candidates` needs a column `t`: the library has ", n_t,
                   " output coordinates.", class = "shape")
    }
    candidates$t <- t_lib
  }
  missing_cols <- setdiff(names(x_lib), names(candidates))
  if (length(missing_cols) > 0L) {
    griddy_abort("`candidates` lacks the library's x column(s) ", show_some(missing_cols), ".")
  }
  table <- candidates[c(names(x_lib), "t")]
  setting <- if (is.null(x_lib)) rep(1L, nrow(table)) else
    match_setting_rows(as.data.frame(as_numeric_matrix(table[names(x_lib)], "candidates")),
                       x_lib)
  j <- vapply(assert_numeric_vector(table$t, "candidates$t"), function(v) {
    hit <- which(same_values(t_lib, v))
    if (length(hit) == 0L) NA_integer_ else hit[which.min(abs(t_lib[hit] - v))]
  }, integer(1))
  bad <- which(is.na(setting) | is.na(j))
  if (length(bad) > 0L) {
    griddy_abort("`candidates` row(s) ", show_some(bad), " are not cells of the library (an ",
                 "x setting and a t it has runs at): next_measurement() weighs the runs' ",
                 "outputs there, and a setting without runs has none.", class = "new_setting")
  }
  rownames(table) <- NULL
  list(table = table, column = (setting - 1L) * n_t + j, row = seq_len(nrow(table)))
}

# The default candidates less the cells a stream under AR(1) has measured
# already (it takes no replicate there).
drop_unmeasurable <- function(cand, models) {
  taken <- Reduce(`|`, lapply(models, function(mod) {
    if (inherits(mod, "griddy_fit") || !mod$state$markov) return(FALSE)
    mod$state$measured[candidate_cells(mod$state$library, cand$table)$column]
  }), FALSE)
  if (all(taken)) {
    griddy_abort("Every cell of the library was measured already, and under an AR(1) ",
                 "correlation over t the stream takes no replicate: no candidate is left.",
                 class = "unsupported")
  }
  list(table = cand$table[!taken, , drop = FALSE], column = cand$column[!taken],
       row = cand$row[!taken])
}

# ---- the components of one model ----------------------------------------------

# The mixture components (run, grid point) of one model, with their weights
# `w` (times the model's probability) and, once subset() to the kept ones,
# `cpp`, what next_gains_cpp() reads, and at(j): the Student-t predictive of
# each component at candidate j (location m, scale s, degrees of freedom nu;
# see next_measurement()), which only the tests' plain-R reference reads
# (tests/testthat/helper-next-measurement.R).
model_components <- function(object, model_prob, columns) {
  if (inherits(object, "griddy_fit")) fit_components(object, model_prob, columns) else
    stream_components(object$state, model_prob, columns)
}

stream_components <- function(state, model_prob, columns) {
  N <- nrow(state$outputs)
  G <- length(state$rho_t)
  joint <- if (sum(state$n) == 0L) {
    normalise_log(outer(state$log_prior_run, state$log_prior_grid, "+"))
  } else {
    exact_from_problem(stream_problem(state), joint = TRUE)$joint
  }
  groups <- state$group[columns]
  nu <- 2 * state$prior$shape + state$n[groups]
  check_degrees(nu)
  neighbours <- lapply(columns, stream_neighbours, state = state)
  subset <- function(keep) {
    run <- (keep - 1L) %% N + 1L
    g <- (keep - 1L) %/% N + 1L
    w <- joint[keep] * model_prob
    # each noise group's squared scales (b + C/2) / (a + n/2), once
    scale2 <- lapply(seq_along(state$labels), function(k) {
      if (!k %in% groups) return(NULL)
      (state$prior$rate + state$C[cbind(run, g + G * (k - 1L))] / 2) /
        (state$prior$shape + state$n[k] / 2)
    })
    at <- function(j) {
      column <- columns[j]
      cond <- ar1_conditional(neighbours[[j]], state, run, g, column)
      list(w = w, m = state$outputs[run, column] + cond$mean,
           s = sqrt(scale2[[groups[j]]] * cond$var), nu = nu[j])
    }
    used <- sort(unique(groups))
    scale_matrix <- matrix(unlist(scale2[used]), length(keep))
    list(at = at, cpp = c(list(w = w, run = run - 1L, g = g - 1L, rho = state$rho_t,
                               outputs = state$outputs, scale2 = scale_matrix, nu = nu,
                               column = columns - 1L, group = match(groups, used) - 1L),
                          stream_neighbour_table(state, neighbours, columns)))
  }
  list(w = as.vector(joint) * model_prob, subset = subset)
}

fit_components <- function(fit, model_prob, columns) {
  setup <- fit$setup
  if (any(unlist(setup$rho_x) != 0) || any(setup$rho_t != 0) || !is.null(setup$discrepancy) ||
      length(setup$group_sizes) > 1L || !is.null(setup$dense$scale) ||
      any(lib_predicted(fit$library))) {
    griddy_abort("next_measurement() of a calibrate() fit takes independent noise with one ",
                 "precision and simulated runs only (no rho_x or rho_t other than 0, no ",
                 "discrepancy, noise groups, relative sd or emulated runs). Give the data to ",
                 "a griddy_stream() (rho_t and noise groups), and rank from it.",
                 class = "unsupported")
  }
  joint <- exact_from_problem(fit, joint = TRUE)$joint
  N <- nrow(joint)
  outputs <- lib_outputs(fit$library)
  a <- fit$prior$shape + fit$n_obs / 2
  nu <- 2 * a
  check_degrees(nu)
  subset <- function(keep) {
    run <- (keep - 1L) %% N + 1L
    s <- sqrt((fit$prior$rate + fit$C[keep] / 2) / a)
    w <- joint[keep] * model_prob
    at <- function(j) list(w = w, m = outputs[run, columns[j]], s = s, nu = nu)
    J <- length(columns)
    none <- rep(-1L, J)
    list(at = at, cpp = list(w = w, run = run - 1L, g = rep(0L, length(keep)), rho = 0,
                             outputs = outputs, scale2 = matrix(s^2, length(keep)),
                             nu = rep(nu, J), column = columns - 1L, group = integer(J),
                             before = none, after = none, y_before = numeric(J),
                             y_after = numeric(J), lag_before = numeric(J),
                             lag_after = numeric(J)))
  }
  list(w = as.vector(joint) * model_prob, subset = subset)
}

check_degrees <- function(nu) {
  if (any(nu < 1)) {
    griddy_abort("A candidate's noise group has no proper predictive yet: its Student-t has ",
                 format(min(nu), digits = 3), " degrees of freedom (2 x prior shape + ",
                 "measurements in the group). Take a measurement in that group first, or ",
                 "give the stream a proper prior on tau (shape at least 1/2).",
                 class = "improper_prior")
  }
}

# The nearest measured outputs before and after `column` at its x setting in
# its noise group (NA where none), for the AR(1) conditional; under AR(1) a
# cell measured already cannot be measured again.
stream_neighbours <- function(state, column) {
  none <- list(before = NA_integer_, after = NA_integer_)
  if (!state$markov) return(none)
  if (state$measured[column]) {
    n_t <- lib_n_t(state$library)
    griddy_abort("Candidate output ", column, " (x setting ", (column - 1L) %/% n_t + 1L,
                 ", t = ", format(lib_t(state$library)[(column - 1L) %% n_t + 1L]),
                 ") was measured already: under an AR(1) correlation over t the stream ",
                 "takes no replicate, so it is no candidate.", class = "unsupported")
  }
  n_t <- lib_n_t(state$library)
  setting <- (column - 1L) %/% n_t
  cols <- state$data$column
  same <- cols[(cols - 1L) %/% n_t == setting & state$group[cols] == state$group[column]]
  before <- same[same < column]
  after <- same[same > column]
  list(before = if (length(before)) max(before) else NA_integer_,
       after = if (length(after)) min(after) else NA_integer_)
}

# The neighbours of each candidate for next_gains_cpp(): columns (0-based,
# -1 for none), their measured values and their distances in unit t.
stream_neighbour_table <- function(state, neighbours, columns) {
  n_t <- lib_n_t(state$library)
  pos <- function(col) state$s_unit[(col - 1L) %% n_t + 1L]
  side <- function(name) {
    col <- vapply(neighbours, `[[`, 0L, name)
    found <- !is.na(col)
    y <- lag <- numeric(length(col))
    y[found] <- state$data$y[match(col[found], state$data$column)]
    lag[found] <- abs(pos(columns[found]) - pos(col[found]))
    list(col = ifelse(found, col - 1L, -1L), y = y, lag = lag)
  }
  b <- side("before")
  a <- side("after")
  list(before = b$col, after = a$col, y_before = b$y, y_after = a$y, lag_before = b$lag,
       lag_after = a$lag)
}

# The AR(1) conditional mean (added to the run's output) and variance factor
# of a new residual at `column` given the runs' residuals at the nearest
# measured neighbours before (e1, lag correlation p1) and after (e2, p2):
# mean (p1 (1 - p2^2) e1 + p2 (1 - p1^2) e2) / (1 - p1^2 p2^2), variance
# (1 - p1^2)(1 - p2^2) / (1 - p1^2 p2^2), which is p1 e1 and 1 - p1^2 with
# no neighbour after (p2 = 0).
ar1_conditional <- function(nb, state, run, g, column) {
  if (is.na(nb$before) && is.na(nb$after)) return(list(mean = 0, var = 1))
  n_t <- lib_n_t(state$library)
  pos <- function(col) state$s_unit[(col - 1L) %% n_t + 1L]
  resid <- function(col) state$data$y[match(col, state$data$column)] - state$outputs[run, col]
  rho <- state$rho_t[g]
  p1 <- if (is.na(nb$before)) 0 else rho^(pos(column) - pos(nb$before))
  p2 <- if (is.na(nb$after)) 0 else rho^(pos(nb$after) - pos(column))
  e1 <- if (is.na(nb$before)) 0 else resid(nb$before)
  e2 <- if (is.na(nb$after)) 0 else resid(nb$after)
  d <- 1 - p1^2 * p2^2
  list(mean = (p1 * (1 - p2^2) * e1 + p2 * (1 - p1^2) * e2) / d,
       var = (1 - p1^2) * (1 - p2^2) / d)
}

# The components to keep (positions in each model's weights): each model's
# largest weights carrying 1 - 1e-4 of its mass, so that a model nearly
# ruled out keeps its components and stays in `gain_model`. Dropping mass
# eps (at most 1e-4 of the whole) changes the exact gain I(Y; K) by at most
# h(eps) + eps max(I, log n dropped), h the binary entropy: with Z the
# indicator of a dropped component, I(Y; K) = I(Y; Z) + (1 - eps) I(Y; K |
# kept) + eps I(Y; K | dropped), where I(Y; Z) <= h(eps) and I(Y; K |
# dropped) <= log n dropped. Up to 10^8 components that is under 0.003 nats,
# about the merge's error; for the model, log n dropped becomes log M.
prune_components <- function(w, tail = 1e-4) {
  lapply(w, function(wm) {
    total <- sum(wm)
    if (total <= 0) return(integer(0))
    o <- order(wm, decreasing = TRUE)
    sort(o[seq_len(min(length(o), sum(cumsum(wm[o]) < (1 - tail) * total) + 1L))])
  })
}

# Gauss-Legendre nodes and weights on (0, 1) (Golub-Welsch).
legendre_rule <- function(n = 32L) {
  k <- seq_len(n - 1L)
  J <- matrix(0, n, n)
  J[cbind(k, k + 1L)] <- J[cbind(k + 1L, k)] <- k / sqrt(4 * k^2 - 1)
  e <- eigen(J, symmetric = TRUE)
  list(u = (e$values + 1) / 2, weight = e$vectors[1, ]^2)
}
