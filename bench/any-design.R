# Coverage of calibrate() -> refine() on the designs users have (issue 13):
# a few tens of simulator runs, either
#   joint     a Latin hypercube over (x, theta) jointly: every run at its own
#             control setting (the Los Alamos simobs / Kennedy-O'Hagan layout),
#   complete  a Latin hypercube over theta, each theta run at every field
#             setting (as many simulator runs in all as the joint design),
# with field data that miss some cells (NA in expobs), read by
# read_calibration_inputs() from the thesis's three files, calibrated with
# calibrate() and refined by refine() without a simulator (the library's
# emulator). Reference: the continuous posterior under the same noise model
# (independent errors, tau integrated out) computed from the true simulator
# on a dense grid.
#
# Systems (two, so that nothing is tuned to one):
#   ball drop   time to fall heights 5..60 m (7 outputs) for balls of radius
#               x in [0.04, 0.2] m with quadratic drag; theta = (drag, gravity)
#   ball3       the same with the ball's density a third parameter in
#               [60, 100] kg/m^3 (only density / drag matters at a given
#               radius, so the posterior is a ridge)
#   projectile  height at 8 times of a projectile launched at angle x in
#               [20, 70] degrees with linear drag; theta = (speed, drag)
# Each trial draws a truth uniformly over the middle 80% of the theta box, a
# design, new noise and a missing pattern (each field cell missing with
# probability 0.2, at least two cells kept per setting).
#
# Run from the package root with griddy installed:
#   Rscript bench/any-design.R        (ANY_TRIALS trials per system and design, default 20)
# Writes bench/results/any-design.csv and prints the summary.

library(griddy)
n_trials <- as.integer(Sys.getenv("ANY_TRIALS", "20"))
n_design <- as.integer(Sys.getenv("ANY_RUNS", "40"))
out_csv <- Sys.getenv("ANY_OUT", "bench/results/any-design.csv")
missing_share <- as.numeric(Sys.getenv("ANY_MISSING", "0.2"))
layouts <- strsplit(Sys.getenv("ANY_LAYOUTS", "joint,complete"), ",")[[1]]

# ---- systems ------------------------------------------------------------------
ball_drop <- function(theta, x, heights = c(5, 10, 20, 30, 40, 50, 60)) {
  radius <- x$radius
  density <- if (is.null(theta$density)) 80 else theta$density
  mass <- density * 4 / 3 * pi * radius^3
  k <- 1.2 * theta$drag * pi * radius^2 / 2
  v_t <- sqrt(mass * theta$gravity / k)
  z <- outer(theta$gravity / v_t^2, heights)
  v_t / theta$gravity * (z + log1p(sqrt(-expm1(-2 * z))))
}
projectile <- function(theta, x, times = seq(0.2, 1.6, length.out = 8)) {
  a <- x$angle * pi / 180
  b <- theta$drag
  g <- 9.81
  vz <- theta$speed * sin(a)
  decay <- -expm1(-outer(b, times))
  (vz + g / b) * decay / b - outer(g / b, times)
}
systems <- list(
  ball = list(sim = ball_drop, t = c(5, 10, 20, 30, 40, 50, 60),
              theta = list(drag = c(0.2, 1), gravity = c(9.5, 10.1)),
              x = list(radius = c(0.04, 0.2)), field_x = data.frame(radius = c(0.05, 0.08, 0.12, 0.17)),
              noise = 0.02),
  ball3 = list(sim = ball_drop, t = c(5, 10, 20, 30, 40, 50, 60),
               theta = list(drag = c(0.2, 1), gravity = c(9.5, 10.1), density = c(60, 100)),
               x = list(radius = c(0.04, 0.2)), field_x = data.frame(radius = c(0.05, 0.08, 0.12, 0.17)),
               noise = 0.02),
  projectile = list(sim = projectile, t = seq(0.2, 1.6, length.out = 8),
                    theta = list(speed = c(15, 25), drag = c(0.05, 0.5)),
                    x = list(angle = c(20, 70)), field_x = data.frame(angle = c(25, 40, 55, 65)),
                    noise = 0.15)
)

lhs <- function(n, ranges) {
  u <- vapply(ranges, function(r) r[1] + diff(r) * (sample.int(n) - stats::runif(n)) / n,
              numeric(n))
  as.data.frame(matrix(u, n, dimnames = list(NULL, names(ranges))))
}

# ---- one trial --------------------------------------------------------------------
make_inputs <- function(sys, layout, truth) {
  if (layout == "joint") {
    runs <- lhs(n_design, c(sys$x, sys$theta))
  } else {
    # as many simulator runs as the joint design: n_design / settings thetas
    th <- lhs(max(10L, n_design %/% nrow(sys$field_x)), sys$theta)
    runs <- merge(sys$field_x, th, by = NULL)
  }
  xs <- runs[names(sys$x)]
  th <- runs[names(sys$theta)]
  simobs <- sys$sim(th, xs)
  clean <- sys$sim(truth[rep(1, nrow(sys$field_x)), , drop = FALSE], sys$field_x)
  y <- clean + stats::rnorm(length(clean), sd = sys$noise)
  miss <- matrix(stats::runif(length(y)) < missing_share, nrow(y))
  for (k in seq_len(nrow(y))) if (sum(!miss[k, ]) < 2) miss[k, sample.int(ncol(y), 2)] <- FALSE
  y[miss] <- NA
  list(design = cbind(xs, th), simobs = simobs, expobs = cbind(sys$field_x, y), y = y)
}

# The continuous posterior of theta under the true simulator (independent
# noise, tau integrated out, uniform prior on the box): a 200 x 200 grid over
# the box, then over the region holding its mass.
continuous_intervals <- function(sys, y) {
  n_axis <- if (length(sys$theta) <= 2L) 200L else 70L
  obs <- !is.na(as.vector(t(y)))
  yv <- as.vector(t(y))[obs]
  post <- function(box) {
    g <- expand.grid(lapply(seq_len(ncol(box)), function(j) seq(box[1, j], box[2, j], length.out = n_axis)))
    names(g) <- names(sys$theta)
    out <- do.call(cbind, lapply(seq_len(nrow(sys$field_x)), function(k) {
      sys$sim(g, sys$field_x[rep(k, nrow(g)), , drop = FALSE])
    }))
    C <- colSums((t(out[, obs, drop = FALSE]) - yv)^2)
    lw <- -(length(yv) / 2) * log(C)
    list(g = g, w = exp(lw - max(lw)))
  }
  box <- sapply(sys$theta, identity)
  p <- post(box)
  keep <- p$w > 1e-10 * max(p$w)
  step <- (box[2, ] - box[1, ]) / (n_axis - 1)
  box2 <- rbind(pmax(apply(p$g[keep, , drop = FALSE], 2, min) - 2 * step, box[1, ]),
                pmin(apply(p$g[keep, , drop = FALSE], 2, max) + 2 * step, box[2, ]))
  p <- post(box2)
  t(vapply(names(sys$theta), function(j) {
    m <- tapply(p$w, p$g[[j]], sum)
    v <- as.numeric(names(m))
    cm <- cumsum(m) / sum(m)
    c(lower = v[which(cm >= 0.025)[1]], upper = v[which(cm >= 0.975)[1]])
  }, numeric(2)))
}

run_trial <- function(sys_name, layout, trial) {
  sys <- systems[[sys_name]]
  set.seed(1000 * trial + match(layout, c("joint", "complete")) + 17 * match(sys_name, names(systems)))
  truth <- as.data.frame(lapply(sys$theta, function(r) r[1] + diff(r) * (0.1 + 0.8 * stats::runif(1))))
  inp <- make_inputs(sys, layout, truth)
  start <- proc.time()[["elapsed"]]
  warned <- character()
  note <- function(w) {
    warned <<- c(warned, class(w)[1])
    invokeRestart("muffleWarning")
  }
  res <- withCallingHandlers({
    lib <- suppressMessages(read_calibration_inputs(inp$design, inp$simobs, inp$expobs, n_x = 1))
    fit <- calibrate(lib$library, lib$field, n_iter = 6000, burn_in = 1000, seed = trial)
    refined <- refine(fit, seed = trial)
    list(lib = lib, fit = fit, refined = refined)
  }, warning = note)
  elapsed <- proc.time()[["elapsed"]] - start
  ref <- continuous_intervals(sys, inp$y)
  st <- summary(res$refined)
  exact <- attr(st, "adequacy")$parameters
  rows <- lapply(names(sys$theta), function(j) {
    s <- exact[exact$parameter == j, ]
    sampled <- st[st$parameter == j, ]
    data.frame(system = sys_name, layout = layout, trial = trial, parameter = j,
               truth = truth[[j]], lower = s$lower, upper = s$upper,
               sampled_lower = sampled$lower, sampled_upper = sampled$upper,
               ref_lower = ref[j, "lower"], ref_upper = ref[j, "upper"],
               library = class(res$lib$library)[1], runs = nrow(res$refined$library$theta),
               emulation_error = if (is.null(res$refined$refinement$emulation_error)) NA else
                 res$refined$refinement$emulation_error,
               warnings = paste(unique(warned), collapse = " "), seconds = elapsed)
  })
  do.call(rbind, rows)
}

system_names <- strsplit(Sys.getenv("ANY_SYSTEMS", paste(names(systems), collapse = ",")), ",")[[1]]
results <- list()
for (sys_name in system_names) for (layout in layouts) {
  for (trial in seq_len(n_trials)) {
    r <- tryCatch(run_trial(sys_name, layout, trial), error = function(e) {
      message(sys_name, " ", layout, " ", trial, ": ", conditionMessage(e))
      NULL
    })
    results[[length(results) + 1L]] <- r
  }
}
d <- do.call(rbind, results)
d$covered <- d$lower <= d$truth & d$truth <= d$upper
d$width_ratio <- (d$upper - d$lower) / (d$ref_upper - d$ref_lower)
d$ref_covered <- d$ref_lower <= d$truth & d$truth <= d$ref_upper
dir.create(dirname(out_csv), showWarnings = FALSE, recursive = TRUE)
utils::write.csv(d, out_csv, row.names = FALSE)
agg <- do.call(rbind, lapply(split(d, list(d$system, d$layout, d$parameter), drop = TRUE), function(s) {
  data.frame(system = s$system[1], layout = s$layout[1], parameter = s$parameter[1], trials = nrow(s),
             coverage = mean(s$covered), reference_coverage = mean(s$ref_covered),
             median_width_ratio = stats::median(s$width_ratio),
             median_seconds = stats::median(s$seconds))
}))
print(agg, row.names = FALSE)
