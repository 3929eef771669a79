# A plain-R reference for next_measurement()'s C++ pass (src/next_gains.cpp):
# the information of one candidate from each model's components there
# (their `at(j)`), the mixture entropy by merging and Gauss-Legendre
# quadrature, as the C++ computes them. test-next-measurement.R checks the
# package's answers against it; the package itself does not use it.

# c(gain, gain_model) at one candidate from each model's components there:
# one merge, into at most 64 components per model, whose merged components
# keep to one model, gives both the mixture's entropy and each model's.
candidate_information <- function(comps) {
  one <- length(comps) == 1L
  glue <- function(field) unlist(lapply(comps, `[[`, field), use.names = FALSE)
  w <- glue("w")
  total <- sum(w)
  sizes <- lengths(lapply(comps, `[[`, "w"))
  nu <- rep(vapply(comps, `[[`, 0, "nu"), sizes)
  model <- rep(seq_along(comps), sizes)
  s <- glue("s")
  log_s <- log(s)
  mc <- merge_components(w / total, glue("m"), s, nu, 64L * length(comps), log_s,
                         class = model, n_classes = length(comps))
  h <- mixture_entropies(mc)
  gain <- h[1] - sum(w / total * t_entropy(nu, s, log_s))
  c(max(gain, 0), if (one) NA_real_ else max(h[1] - h[2], 0))
}

# The entropy of a Student-t with nu degrees of freedom and scale s: log s
# plus a constant of nu, computed once per distinct nu.
t_entropy <- function(nu, s, log_s = log(s)) {
  log_s + by_distinct(nu, function(v) {
    (v + 1) / 2 * (digamma((v + 1) / 2) - digamma(v / 2)) + log(sqrt(v) * beta(v / 2, 0.5))
  })
}

# The log density of a Student-t at standardised z (scale left out); nu one
# value, or one per column of the matrix z.
t_log_kernel <- function(z, nu) {
  const <- lgamma((nu + 1) / 2) - lgamma(nu / 2) - log(nu * pi) / 2
  if (length(nu) == 1L) return(const - (nu + 1) / 2 * log1p(z^2 / nu))
  r <- nrow(z)
  rep(const, each = r) - rep((nu + 1) / 2, each = r) * log1p(z^2 / rep(nu, each = r))
}

# f(v) for each element of v, evaluated once per distinct value (the
# degrees of freedom take one value per model and noise group).
by_distinct <- function(v, f) {
  u <- unique(v)
  if (length(u) == 1L) return(rep(f(u), length(v)))
  f(u)[match(v, u)]
}

# The entropy of the mixture sum w t_nu(m, s) (w sums to 1): merged
# (merge_components()), then sum_j w_j [H(p_j) + KL(p_j || p)], each KL by
# Gauss-Legendre quadrature over the component's quantiles.
mixture_entropy <- function(w, m, s, nu, max_components = 64L, log_s = log(s)) {
  mixture_entropies(merge_components(w, m, s, nu, max_components, log_s))[1]
}

# c(the entropy of the merged mixture mc, sum over its classes (models) of
# the class's mass times its own mixture's entropy): each KL of a component
# against the whole mixture and against its class's part, at the same nodes.
mixture_entropies <- function(mc) {
  if (length(mc$w) == 1L) return(rep(t_entropy(mc$nu, mc$s), 2))
  rule <- legendre_rule()
  Q <- length(rule$u)
  nus <- unique(mc$nu)
  quantiles <- vapply(nus, function(v) stats::qt(rule$u, v), numeric(Q))
  z <- matrix(quantiles, Q)[, match(mc$nu, nus), drop = FALSE]   # Q x components
  y <- as.vector(z * rep(mc$s, each = Q) + rep(mc$m, each = Q))   # the nodes
  classes <- unique(mc$class)
  dens <- vapply(classes, function(k) {
    mixture_density(y, lapply(mc, function(v) v[mc$class == k]))
  }, numeric(length(y)))
  dens <- matrix(dens, length(y))
  log_pj <- t_log_kernel(z, mc$nu) - rep(log(mc$s), each = Q)
  h_part <- t_entropy(mc$nu, mc$s)
  kl <- colSums(rule$weight * (log_pj - matrix(log(rowSums(dens)), Q)))
  mass <- vapply(classes, function(k) sum(mc$w[mc$class == k]), 0)
  own <- rep(match(mc$class, classes), each = Q)
  log_own <- log(dens[cbind(seq_along(y), own)]) - log(mass[own])
  kl_class <- colSums(rule$weight * (log_pj - matrix(log_own, Q)))
  c(sum(mc$w * (h_part + kl)), sum(mc$w * (h_part + kl_class)))
}

# The mixture's density at y: the squared standardised distances from a
# matrix product (about the components' centre, which keeps the
# cancellation small), then one matrix-vector product per distinct nu.
# Each node lies within a component's central 99.7% (or so), so the
# density there never underflows.
mixture_density <- function(y, mc) {
  centre <- sum(mc$w * mc$m)
  yc <- y - centre
  mu <- mc$m - centre
  inv <- 1 / mc$s^2
  # (rounding may leave a distance of 0 slightly negative: harmless in log(1 + Z2 / v))
  Z2 <- cbind(yc^2, yc, 1) %*% rbind(inv, -2 * mu * inv, mu^2 * inv)
  p <- numeric(length(y))
  for (v in unique(mc$nu)) {
    j <- which(mc$nu == v)
    const <- exp(lgamma((v + 1) / 2) - lgamma(v / 2) - log(v * pi) / 2)
    D <- exp(-(v + 1) / 2 * log(1 + Z2[, j, drop = FALSE] / v))
    p <- p + const * as.vector(D %*% (mc$w[j] / mc$s[j]))
  }
  p
}

# Components merged into at most `max_components`: those in one bin of
# location (width a quarter of the scale) and log scale (width 0.05), per
# class (by default, per degrees of freedom; next_measurement() uses the
# model), become one with their weight, mean and variance (squared scale:
# the weighted mean square scale plus the locations' variance). While too
# many remain, the bins widen (src/merge_components.cpp). Given, `class`
# takes values in 1..n_classes.
merge_components <- function(w, m, s, nu, max_components, log_s = log(s), class = NULL,
                             n_classes = max(class)) {
  nu <- rep_len(nu, length(w))
  if (is.null(class)) {
    class <- match(nu, unique(nu))
    n_classes <- max(class)
  }
  if (length(w) <= 1L) return(list(w = w, m = m, s = s, nu = nu, class = class))
  out <- merge_components_cpp(w, m, s, log_s, class, n_classes, 0.25, 0.05, max_components)
  list(w = out$w, m = out$m, s = sqrt(out$s2), nu = nu[match(out$nu_class, class)],
       class = out$nu_class)
}
