peak <- function(fz, block = 1L, n = 500L) apply(fz[, (block - 1L) * n + seq_len(n), drop = FALSE], 1, max)

test_that("tyre_cleat_model returns N x (heights * 500) with time and height", {
  fz <- tyre_cleat_model(k = c(100, 400), c = 1, height = 27.44)
  expect_identical(dim(fz), c(2L, 500L))
  expect_equal(attr(fz, "time"), seq_len(500) / 1000)
  expect_identical(attr(fz, "height"), 27.44)
  fz3 <- tyre_cleat_model(k = c(100, 400), c = 1)
  expect_identical(dim(fz3), c(2L, 1500L))
  expect_equal(attr(fz3, "height"), tyre_cleat_heights())
  # blocks by height, in the given order
  expect_equal(unname(fz3[, 1001:1500]),
               unname(tyre_cleat_model(k = c(100, 400), c = 1, height = 12.13)[, 1:500]),
               ignore_attr = TRUE)
  # a matrix of parameter rows gives the same as k and c vectors
  m <- cbind(k = c(100, 400), c = c(1, 2))
  expect_equal(tyre_cleat_model(m, height = 12.13), tyre_cleat_model(c(100, 400), c(1, 2), height = 12.13))
  expect_true(all(is.finite(fz3)) && all(fz3 >= 0))
})

test_that("the rig starts in static equilibrium and the static deflection is load / k", {
  k <- c(50, 210, 800)
  expect_equal(tyre_static_deflection(k), 3000 / k, tolerance = 1e-9)
  for (ct in c("point", "patch")) {
    fz <- tyre_cleat_model(k, 0.5, height = 27.44, contact = ct)
    expect_equal(unname(fz[, 1:10]), matrix(3000, 3, 10), tolerance = 1e-9,  # before the cleat
                 info = ct)
  }
  # PAC2002-style static deflection solves its own polynomial
  rho <- tyre_static_deflection(210, model = "pac2002") / 1000
  p <- tyre_pac2002()
  x <- rho / 0.3135
  f <- (1 + p$qV2 * 20 / p$V0) * ((210e3 * 0.3135 / p$Fz0) * x + p$qFz2 * x^2) * p$Fz0
  expect_equal(f, 3000, tolerance = 1e-8)
})

test_that("peak force rises with stiffness and cleat height", {
  k <- seq(50, 800, length.out = 6)
  for (ct in c("point", "disc", "patch")) {
    fz <- tyre_cleat_model(k, 0.5, contact = ct)
    for (b in 1:3) expect_true(all(diff(peak(fz, b)) > 0), info = paste(ct, b))
    # heights are 41.2, 27.44, 12.13 mm: peaks fall with the height
    expect_true(all(peak(fz, 1) > peak(fz, 2) & peak(fz, 2) > peak(fz, 3)))
  }
})

test_that("damping makes the free decay die out faster", {
  fz <- tyre_cleat_model(210, c(0.2, 2), height = 27.44, contact = "disc")
  late <- 300:500                                 # 0.3 - 0.5 s, long after the cleat
  dev <- apply(abs(fz[, late] - 3000), 1, max)
  expect_lt(dev[2], dev[1])
  expect_lt(dev[2], 1)                            # heavily damped: back to the static load
})

test_that("output is insensitive to halving the internal time step", {
  k <- c(50, 210, 800)
  c <- c(0, 0.5, 5)
  for (ct in c("point", "disc", "patch")) {
    a <- tyre_cleat_model(k, c, contact = ct)
    b <- tyre_cleat_model(k, c, contact = ct, rig = tyre_rig(steps_per_sample = 200))
    expect_lt(max(abs(a - b)) / max(a), 0.01)
    # at moderate damping the difference is a few newtons
    expect_lt(max(abs(a[2, ] - b[2, ])), 50)
  }
})

test_that("each PAC2002 effect switched off reproduces the simpler model", {
  k <- c(80, 210, 600)
  c <- c(0.1, 0.5, 3)
  off <- tyre_pac2002(qFz2 = 0, qV2 = 0)
  fiala <- tyre_cleat_model(k, c, model = "fiala", contact = "point")
  pac_off <- tyre_cleat_model(k, c, model = "pac2002", contact = "point", pac = off)
  expect_equal(pac_off, fiala, tolerance = 1e-9)
  # camber without qFz3 and pressure without qpFz1 change nothing
  expect_equal(tyre_cleat_model(k, c, model = "pac2002", contact = "point", camber = 0.05,
                                pac = off), fiala, tolerance = 1e-9)
  expect_equal(tyre_cleat_model(k, c, model = "pac2002", contact = "point",
                                pac = tyre_pac2002(qFz2 = 0, qV2 = 0, qpFz1 = 0),
                                pressure = 2.6e5), fiala, tolerance = 1e-9)
  # Fiala ignores camber and pressure
  expect_equal(tyre_cleat_model(k, c, contact = "point", camber = 0.05, pressure = 2.6e5), fiala,
               tolerance = 1e-12)
  # each effect switched on changes the signal
  on <- list(tyre_cleat_model(k, c, model = "pac2002", contact = "point", pac = tyre_pac2002(qV2 = 0)),
             tyre_cleat_model(k, c, model = "pac2002", contact = "point", pac = tyre_pac2002(qFz2 = 0)),
             tyre_cleat_model(k, c, model = "pac2002", contact = "point", camber = 0.05,
                              pac = tyre_pac2002(qFz2 = 0, qV2 = 0, qFz3 = 3)),
             tyre_cleat_model(k, c, model = "pac2002", contact = "point", pressure = 2.6e5, pac = off),
             tyre_cleat_model(k, c, model = "pac2002", contact = "disc", pac = off))
  for (i in seq_along(on)) expect_gt(max(abs(on[[i]] - fiala)), 100, label = paste("effect", i))
  # qV2 at one speed is a pure stiffness scale: equals Fiala with k * sV
  sv <- 1 + 0.034 * 20 / 16.6
  expect_equal(tyre_cleat_model(k, c, model = "pac2002", contact = "point",
                                pac = tyre_pac2002(qFz2 = 0)),
               tyre_cleat_model(k * sv, c, contact = "point"), tolerance = 1e-8)
  # default contact (thesis, sec. 5.1): rectangular patch for Fiala, rigid disc for PAC2002
  expect_equal(tyre_cleat_model(210, 0.5, model = "pac2002"),
               tyre_cleat_model(210, 0.5, model = "pac2002", contact = "disc"))
  expect_equal(tyre_cleat_model(210, 0.5), tyre_cleat_model(210, 0.5, contact = "patch"))
  expect_false(isTRUE(all.equal(tyre_cleat_model(210, 0.5),
                                tyre_cleat_model(210, 0.5, contact = "point"))))
})

test_that("patch contact: a chord of the unloaded tyre, the static solution on a flat road", {
  k <- c(50, 210, 450, 800)
  rho0 <- 3000 / k
  expect_equal(tyre_patch_length(k), 2 * sqrt(2 * 313.5 * rho0 - rho0^2), tolerance = 1e-9)
  # the PAC2002-style tyre's chord is at its own static deflection
  rho_pac <- tyre_static_deflection(210, model = "pac2002")
  expect_equal(tyre_patch_length(210, model = "pac2002"),
               2 * sqrt(2 * 313.5 * rho_pac - rho_pac^2), tolerance = 1e-9)
  expect_equal(tyre_patch_length(k, rig = tyre_rig(patch_length = 150)), rep(150, 4))
  # a cleat too low to reach: the patch stands still at the static load throughout
  for (L in list(NULL, 40)) {
    fz <- tyre_cleat_model(k, c(0, 0.5, 1.5, 5), height = 1e-9,
                           rig = tyre_rig(patch_length = L))
    expect_equal(unclass(fz), matrix(3000, 4, 500), tolerance = 1e-9, ignore_attr = TRUE)
  }
  # before the patch's front edge reaches the cleat (20 ms x 20 m/s = 400 mm),
  # the force is the static load; just after, it is not
  a <- tyre_patch_length(50) / 2
  fz <- tyre_cleat_model(50, 0.5, height = 27.44)
  reach <- (400 - a) / 20                       # ms
  expect_equal(unname(fz[1, seq_len(floor(reach))]), rep(3000, floor(reach)), tolerance = 1e-9)
  expect_gt(fz[1, ceiling(reach) + 1], 3001)
})

test_that("patch contact bounds the force over the cleat where the point follower spikes", {
  # Bound: static load + twice the spring force of the patch-averaged cleat
  # (an undamped oscillator overshoots a step by at most its size) + the
  # damping force at the patch's largest rate c V h / (2a).
  g <- expand.grid(k = c(50, 210, 450, 800), c = c(0, 1.5, 5))
  h <- tyre_cleat_heights()
  two_a <- tyre_patch_length(g$k) / 1000                                  # m
  bound <- vapply(h / 1000, function(hh) {
    3000 + 2 * g$k * 1e3 * hh * pmin(1, 0.1 / two_a) + g$c * 1e3 * 20 * hh / two_a
  }, numeric(nrow(g)))
  peaks <- function(contact) {
    fz <- tyre_cleat_model(as.matrix(g), contact = contact)
    vapply(1:3, function(b) peak(fz, b), numeric(nrow(g)))
  }
  patch <- peaks("patch")
  expect_true(all(patch < bound))
  # the point follower breaks the bound wherever there is damping: at the
  # thesis's truth (450, 1.5) its edge spike is 75 kN, 25 times the load
  point <- peaks("point")
  damped <- g$c > 0 & g$k <= 450
  expect_true(all(point[damped, ] > bound[damped, ]))
  truth <- g$k == 450 & g$c == 1.5
  expect_gt(point[truth, 1], 20 * 3000)
  expect_lt(patch[truth, 1], 7 * 3000)
})

test_that("patch contact converges in the time step", {
  k <- c(50, 450, 800)
  c <- c(0, 1.5, 5)
  err <- function(steps) {
    ref <- tyre_cleat_model(k, c, rig = tyre_rig(steps_per_sample = 800))
    max(abs(tyre_cleat_model(k, c, rig = tyre_rig(steps_per_sample = steps)) - ref))
  }
  e <- vapply(c(25, 100, 400), err, numeric(1))
  expect_true(all(diff(e) < 0))                 # smaller steps, smaller error
  expect_lt(e[2] / max(tyre_cleat_model(k, c)), 0.005)
})

test_that("patch contact tends to the point follower as the patch shrinks", {
  k <- c(50, 450, 800)
  c <- c(0, 1.5, 5)
  point <- tyre_cleat_model(k, c, contact = "point")
  gap <- vapply(c(10, 1, 0.001), function(len) {
    max(abs(tyre_cleat_model(k, c, rig = tyre_rig(patch_length = len)) - point))
  }, numeric(1))
  expect_true(all(diff(gap) < 0))
  # N, against peaks of up to 200 kN.  Below 1 mm the gap shrinks in
  # proportion to the patch length (the patch meets the cleat a / V earlier,
  # inside a time step), but not monotonically between 0.1 and 0.01 mm: at
  # k = 800 N/mm, c = 5 N s/mm the wheel is launched and its landing time
  # amplifies the difference.
  expect_lt(gap[3], 5)
  expect_gt(gap[1], 1000)                       # a 10 mm patch already differs
})

test_that("cleat heights: rescaled by default, literal on request", {
  expect_equal(tyre_cleat_heights(), c(41.2, 27.44, 12.13))
  expect_equal(tyre_cleat_heights("thesis_literal"), c(412, 274.4, 121.3))
  expect_warning(fz <- tyre_cleat_model(210, 0.5, height = 412, rig = tyre_rig(bottoming = TRUE)),
                 "not below the unloaded radius")
  expect_true(all(is.finite(fz)))
  # (the point follower: a 187 mm patch feels the 100 mm cleat at half its
  # height, and the tyre does not reach its rim)
  fz <- tyre_cleat_model(210, 0.5, height = 121.3, contact = "point",
                         rig = tyre_rig(bottoming = TRUE, sample = "instant"))
  fz0 <- tyre_cleat_model(210, 0.5, height = 121.3, contact = "point",
                          rig = tyre_rig(sample = "instant"))
  expect_gt(max(fz), max(fz0))                    # the rim bottoms out
})

test_that("tyre_cleat_model validates its inputs", {
  expect_error(tyre_cleat_model(k = -1), "`k` must be", class = "griddy_error_input")
  expect_error(tyre_cleat_model(k = 100, c = NA), "`c` must be", class = "griddy_error_input")
  expect_error(tyre_cleat_model(k = 1:3, c = 1:2), "recyclable", class = "griddy_error_input")
  expect_error(tyre_cleat_model(cbind(k = 1, c = 1), c = 1), "`c` must be missing",
               class = "griddy_error_input")
  expect_error(tyre_cleat_model(cbind(a = 1, b = 1)), "columns `k` and `c`",
               class = "griddy_error_input")
  expect_error(tyre_cleat_model(cbind(k = 1, k = 2, c = 1)), "`k` has duplicated column names: k",
               class = "griddy_error_input")
  expect_error(tyre_cleat_model(height = 0), "`height` must be", class = "griddy_error_input")
  expect_error(tyre_cleat_model(contact = "cams"),
               "`contact` must be one of \"point\", \"disc\", \"patch\"",
               class = "griddy_error_input")
  expect_error(tyre_rig(patch_length = 0), "`patch_length` must be 1 finite number in \\(0, Inf\\]",
               class = "griddy_error_input")
  expect_error(tyre_rig(patch_length = c(100, 120)), "`patch_length` must be 1 finite number",
               class = "griddy_error_input")
  expect_error(tyre_cleat_model(model = "swift"), "`model` must be one of \"fiala\", \"pac2002\"",
               class = "griddy_error_input")
  expect_error(tyre_cleat_model(rig = list()), "`rig` must come from tyre_rig",
               class = "griddy_error_input")
  expect_error(tyre_cleat_model(pac = list()), "`pac` must come from tyre_pac2002",
               class = "griddy_error_input")
  expect_error(tyre_rig(edge_length = 60), "`edge_length` must be at most half",
               class = "griddy_error_input")
  expect_error(tyre_rig(rim_radius = 0.4), "`rim_radius` must be smaller than `R0`",
               class = "griddy_error_input")
  expect_error(tyre_rig(steps_per_sample = 0.5), "`steps_per_sample` must be a single whole number",
               class = "griddy_error_input")
  expect_error(tyre_rig(n_samples = 2^31), "`n_samples` must be a single whole number in 1..1e\\+07",
               class = "griddy_error_input")
  expect_error(tyre_rig(bottoming = NA), "`bottoming` must be TRUE or FALSE",
               class = "griddy_error_input")
  expect_error(tyre_rig(sample = "median"), "`sample` must be one of \"mean\", \"instant\"",
               class = "griddy_error_input")
  expect_error(tyre_cleat_heights("literal"), "`which` must be one of", class = "griddy_error_input")
  expect_error(tyre_cleat_model(model = "pac2002", pressure = 1e3,
                                pac = tyre_pac2002(qpFz1 = 2)), "non-positive stiffness",
               class = "griddy_error_input")
  expect_warning(tyre_cleat_model(210, 0.5, height = 400, rig = tyre_rig(n_samples = 5)),
                 "not below the unloaded radius", class = "griddy_warning_input")
})

test_that("tyre_static_deflection validates what tyre_cleat_model does", {
  expect_error(tyre_static_deflection(100, pac = list()), "`pac` must come from tyre_pac2002",
               class = "griddy_error_input")
  expect_error(tyre_static_deflection(100, rig = 1), "`rig` must come from tyre_rig",
               class = "griddy_error_input")
  expect_error(tyre_static_deflection(100, speed = -1), "`speed` must be",
               class = "griddy_error_input")
  expect_error(tyre_static_deflection(100, camber = 3), "`camber` must be",
               class = "griddy_error_input")
  expect_error(tyre_static_deflection(100, pressure = NA), "`pressure` must be",
               class = "griddy_error_input")
  expect_error(tyre_static_deflection(100, model = "swift"), "`model` must be one of",
               class = "griddy_error_input")
})

test_that("end to end: a small tyre library calibrates to within one library step", {
  # A 16 x 11 grid (steps 50 N/mm and 0.5 N s/mm) at two heights and 150
  # samples; the truth (460, 1.6) lies between grid points and is held out.
  rig <- tyre_rig(n_samples = 150)
  heights <- c(27.44, 12.13)
  theta <- expand.grid(k = seq(50, 800, by = 50), c = seq(0, 5, by = 0.5))
  y <- tyre_cleat_model(as.matrix(theta), height = heights, rig = rig)
  lib <- sim_library(theta, unclass(y)[, , drop = FALSE], x = data.frame(height = heights),
                     t = attr(y, "time"))
  f <- tyre_field_data(k = 460, c = 1.6, height = heights, noise_sd = 60, seed = 1, rig = rig)
  # 300 data points put (nearly) all the mass on one run, and calibrate() says so
  expect_warning(fit <- calibrate(lib, f, n_iter = 3000, burn_in = 1000, seed = 2),
                 class = "griddy_warning_resolution",
                 regexp = "resolution: k \\([0-9.]+ effective values\\), c \\(")
  s <- summary(fit)
  expect_identical(s$resolution[1:2], c("limited", "limited"))
  expect_lte(abs(s$median[s$parameter == "k"] - 460), 50)
  expect_lte(abs(s$median[s$parameter == "c"] - 1.6), 0.5)
  # the fitted misfit is at least the noise we added
  expect_gt(stats::median(1 / sqrt(fit$draws$tau)), 50)
  # the sampler agrees with the exact posterior over runs
  expect_lt(attr(s, "adequacy")$tv_distance, 0.05)
})

# Issue 35, item 4: a fixed step that ran across a contact event (touch-down,
# lift-off, the disc's contact point jumping onto the cleat) put the event at
# a stage evaluation, so the outputs jumped as k or c moved it across one:
# the log likelihood of chapter 5's PAC2002-style data jumped by up to 11
# units between neighbouring values 0.005 N/mm apart.  With the events
# located within the step it is smooth.  Measure: the second differences of
# the log likelihood along a line (a smooth curve's are small and alike; a
# jump of J gives two of about J).  Here they are at most 0.01 (k) and 0.05
# (c); the fixed-step code gave 8.5 and 8.0 (and first differences of 8.8
# and 9.1 log units).
test_that("the disc's likelihood is smooth in k and c near chapter 5's nine-parameter fit", {
  obs <- as.vector(tyre_cleat_model(450, 1.5, model = "pac2002", height = 41.2))
  obs <- obs + withr::with_seed(502, stats::rnorm(length(obs), sd = 60))
  centre <- c(k = 489.1044, c = 1.502486)
  for (p in c("k", "c")) {
    th <- matrix(centre, 21, 2, byrow = TRUE, dimnames = list(NULL, c("k", "c")))
    th[, p] <- centre[[p]] + seq(-1, 1, length.out = 21) * c(k = 0.1, c = 0.001)[[p]]
    ss <- rowSums((tyre_cleat_model(th, height = 41.2, contact = "disc") -
                     rep(obs, each = 21))^2)
    log_lik <- -length(obs) / 2 * log(ss)
    expect_lt(max(abs(diff(log_lik, differences = 2))), 0.5)
  }
})

test_that("contact events keep the default step within 1 N of a 10 times finer one", {
  th <- cbind(k = c(100, 489, 750), c = c(4.5, 1.5, 0.2))
  for (contact in c("patch", "disc")) {
    coarse <- tyre_cleat_model(th, contact = contact)
    fine <- tyre_cleat_model(th, contact = contact, rig = tyre_rig(steps_per_sample = 1000))
    expect_lt(max(abs(coarse - fine)), 1)
  }
})

test_that("the mean force over a sample is the impulse the integrator applied", {
  # in free flight the force is exactly 0, never a rounding error below it
  fz <- tyre_cleat_model(800, 5, contact = "point")
  expect_true(any(fz == 0))
  expect_true(all(fz >= 0))
  # at rest before the cleat the sample means are the load
  expect_equal(unname(fz[1, 1:19]), rep(3000, 19), tolerance = 1e-9)
})
