truth <- c(1000, 3000, 2000)

test_that("piston_model returns the documented shapes", {
  y <- piston_model(truth)
  expect_true(is.matrix(y))
  expect_identical(dim(y), c(1L, 27L))
  expect_identical(colnames(y)[c(1, 10, 27)],
                   c("full:undercrown1", "full:gallery11", "full:gallery29"))
  h <- rbind(truth, truth * 2, truth / 2)
  y3 <- piston_model(h)
  expect_identical(dim(y3), c(3L, 27L))
  expect_equal(y3[1, ], y[1, ])
  expect_identical(dim(piston_model(h, locations = piston_location_ids(2))), c(3L, 6L))
  y54 <- piston_model(h, condition = c("full", "part"))
  expect_identical(dim(y54), c(3L, 54L))
  expect_equal(y54[, 1:27], y3)
  expect_equal(unname(y54[, 28:54]), unname(piston_model(h, condition = "part")))
  # data.frame input is accepted
  expect_equal(piston_model(as.data.frame(h)), y3)
})

test_that("piston locations cover the three surfaces", {
  loc <- piston_locations()
  expect_identical(nrow(loc), 27L)
  expect_identical(names(loc), c("id", "surface", "index", "r_mm", "z_mm", "r", "z"))
  expect_identical(as.vector(table(loc$surface)[c("undercrown", "gallery1", "gallery2")]),
                   c(9L, 9L, 9L))
  expect_false(anyDuplicated(loc[, c("r_mm", "z_mm")]) > 0)
  expect_true(all(loc$r >= 0 & loc$r <= 1 & loc$z >= 0 & loc$z <= 1))
  for (n in c(1, 2, 5, 9)) {
    ids <- piston_location_ids(n)
    expect_length(ids, 3 * n)
    expect_setequal(unique(piston_locations(ids)$surface),
                    c("undercrown", "gallery1", "gallery2"))
  }
  expect_true(all(piston_location_ids(2) %in% piston_location_ids(5)))
  expect_error(piston_location_ids(10), "`n_per_surface` must be")
})

test_that("temperatures fall as each coefficient rises", {
  rng <- piston_htc_ranges()
  grid <- exp(seq(log(15), log(12000), length.out = 8))
  for (j in 1:3) {
    for (other in list(c(1000, 3000, 2000), c(100, 100, 100), c(12000, 12000, 12000))) {
      h <- matrix(other, length(grid), 3, byrow = TRUE)
      h[, j] <- grid
      y <- piston_model(h, condition = c("full", "part"))
      expect_true(all(diff(y) < 0), info = paste("coefficient", j))
    }
  }
})

test_that("each surface responds most to its own coefficient", {
  # Checked at the truth and at points where no surface is nearly adiabatic;
  # when a surface's own coefficient is far below its neighbours' its own
  # sensitivity vanishes (d T / d log h -> 0 as h -> 0) and a neighbour wins.
  sens <- function(base) {
    f <- function(h) {
      y <- piston_model(h)
      c(mean(y[1:9]), mean(y[10:18]), mean(y[19:27]))
    }
    b <- f(base)
    sapply(1:3, function(j) {
      h <- base
      h[j] <- h[j] * 1.1
      (f(h) - b) / log(1.1)
    })
  }
  for (base in list(truth, c(6000, 6000, 6000), c(100, 100, 100), c(12000, 12000, 12000),
                    c(2000, 8000, 4000))) {
    s <- abs(sens(base))                                 # rows: surface, cols: coefficient
    expect_identical(apply(s, 1, which.max), 1:3, info = paste(base, collapse = ","))
  }
})

test_that("temperatures stay bounded and physical over table 3.1's ranges", {
  rng <- piston_htc_ranges()
  corners <- as.matrix(expand.grid(c(rng$min[1], rng$max[1]), c(rng$min[2], rng$max[2]),
                                   c(rng$min[3], rng$max[3])))
  y <- piston_model(corners, condition = c("full", "part"))
  expect_true(all(is.finite(y)))
  expect_true(all(y > 109 & y < 950))                   # between the coolest fluid and the gas
  y0 <- piston_model(truth)
  expect_true(all(y0 > 120 & y0 < 420))
})

test_that("heat in equals heat out", {
  for (h in list(truth, c(13.85, 8.61, 35.33), c(11984.7, 11977.45, 12002.49))) {
    for (cond in c("full", "part")) {
      hb <- piston_heat_balance(h, condition = cond)
      heat_in <- hb$flows$heat[hb$flows$zone == "gas"]
      heat_out <- -sum(hb$flows$heat[hb$flows$zone != "gas"])
      expect_gt(heat_in, 0)
      expect_equal(heat_out, heat_in, tolerance = 1e-8)
      # the three oil-cooled surfaces always take heat out (oil is the coolest fluid)
      htc_zones <- hb$flows$zone %in% c("undercrown", "gallery1", "gallery2")
      expect_true(all(hb$flows$heat[htc_zones] < 0))
    }
  }
  hb <- piston_heat_balance(truth, field = TRUE)
  expect_true(max(hb$field$temperature) < 950)
  # face temperatures of piston_model lie between the adjacent cell and the fluid
  expect_true(all(hb$field$temperature > 110))
})

test_that("grid refinement changes the outputs little", {
  a <- piston_model(truth, cell = 1)
  b <- piston_model(truth, cell = 0.5)
  expect_lt(max(abs(a - b)), 10)
  expect_lt(mean(abs(a - b)), 3)
})

test_that("aluminium has a cooler crown than steel", {
  t_al <- piston_heat_balance(truth, material = "aluminium", field = TRUE)$field$temperature
  t_st <- piston_heat_balance(truth, field = TRUE)$field$temperature
  expect_lt(max(t_al), max(t_st) - 50)
})

test_that("piston_model validates its inputs", {
  expect_error(piston_model(c(1, 2)), "`htc` must have 3 values", class = "griddy_error_input")
  expect_error(piston_model("a"), "`htc` must be a numeric matrix or data.frame; received character",
               class = "griddy_error_input")
  expect_error(piston_model(matrix(1, 2, 4)), "`htc` must have 3 column\\(s\\); received 2 x 4",
               class = "griddy_error_input")
  expect_error(piston_model(matrix(1, 0, 3)), "`htc` must have at least 1 row",
               class = "griddy_error_input")
  expect_error(piston_model(c(1, -2, 3)),
               "`htc` must lie in \\(0, Inf\\] \\(W/m\\^2K\\); received -2 at \\[1, 2\\]",
               class = "griddy_error_input")
  expect_error(piston_model(c(1, NA, 3)), "`htc` must hold finite numbers; found NA at \\[1, 2\\]",
               class = "griddy_error_input")
  expect_error(piston_model(data.frame(a = 1, b = factor("2"), c = 3)),
               "`htc` must be numeric; column\\(s\\) b are factor", class = "griddy_error_input")
  expect_error(piston_model(c(TRUE, TRUE, TRUE)), "received logical", class = "griddy_error_input")
  expect_error(piston_model(truth, locations = 28), "`locations` must be distinct whole numbers in 1..27; received 28",
               class = "griddy_error_input")
  expect_error(piston_model(truth, locations = c(1, 1)), "received 1, 1", class = "griddy_error_input")
  expect_error(piston_model(truth, locations = 2^31), "in 1..27", class = "griddy_error_input")
  expect_error(piston_model(truth, locations = integer(0)), "received nothing", class = "griddy_error_input")
  expect_error(piston_model(truth, condition = "idle"),
               "`condition` must be one or more distinct of \"full\", \"part\"; received \"idle\"",
               class = "griddy_error_input")
  expect_error(piston_model(truth, material = c("steel", "aluminium")),
               "`material` must be one of \"steel\", \"aluminium\"", class = "griddy_error_input")
  expect_error(piston_model(truth, cell = 2), "`cell` must be one of 0.25, 0.5, 1; received 2",
               class = "griddy_error_input")
  expect_error(piston_model(truth, cell = NA), "`cell` must be one of", class = "griddy_error_input")
  expect_error(piston_heat_balance(rbind(truth, truth)), "`htc` must be a single set of 3",
               class = "griddy_error_input")
  expect_error(piston_heat_balance(truth, condition = c("full", "part")),
               "`condition` must be one of", class = "griddy_error_input")
  expect_error(piston_heat_balance(truth, field = "yes"), "`field` must be TRUE or FALSE",
               class = "griddy_error_input")
  expect_error(piston_location_ids(2^31), "`n_per_surface` must be a single whole number in 1..9",
               class = "griddy_error_input")
  expect_error(piston_location_ids(NA), "`n_per_surface`", class = "griddy_error_input")
  expect_error(piston_locations(0), "`locations`", class = "griddy_error_input")
})

test_that("integer64 coefficients are read as numbers", {
  skip_if_not_installed("bit64")
  expect_equal(piston_model(bit64::as.integer64(truth)), piston_model(truth))
})

test_that("a conductivity slope with no solution for the temperature warns", {
  # k(T) = k0 (1 + alpha (T - 20)) vanishes at T = 20 - 1 / alpha; the hottest
  # constant-conductivity temperatures have no T with that slope
  low <- c(14, 9, 36)
  expect_warning(hot <- piston_model(low, conductivity_slope = -9.9e-4),
                 "conductivity_slope.*no solution.*row\\(s\\) 1", class = "griddy_warning_numeric")
  expect_no_warning(piston_model(low, conductivity_slope = -3e-4))
})

test_that("the optional effects are off by default and reproduce the base model at 0", {
  htc <- rbind(c(1000, 3000, 2000), c(500, 8000, 300))
  base <- piston_model(htc)
  expect_identical(piston_model(htc, gallery_gradient = 0, conductivity_slope = 0), base)
  # the graded-gallery solver in R agrees with the C++ one when the grade is ~0
  st <- piston_setup("full", 1, "steel")
  expect_equal(unname(piston_eval_graded(st, htc, c(0, 0), 1:27)), unname(base),
               tolerance = 1e-10)
})

test_that("a graded gallery coefficient and a temperature-dependent conductivity act", {
  htc <- c(1000, 3000, 2000)
  base <- piston_model(htc)
  graded <- piston_model(htc, gallery_gradient = 0.5)
  g1 <- grepl("gallery1", colnames(base))
  expect_gt(max(abs(graded - base)[g1]), 1)
  # the mean coefficient is unchanged, so gallery-1 temperatures move both ways
  d <- (graded - base)[g1]
  expect_true(any(d > 0) && any(d < 0))
  soft <- piston_model(htc, conductivity_slope = -3e-4)
  # k falls with T: U = T + alpha (T - 20)^2 / 2 < T, so the hot points get hotter
  expect_true(all(soft >= base))
  expect_equal(soft[1, ] + (-3e-4) * (soft[1, ] - 20)^2 / 2, base[1, ], tolerance = 1e-10)
  both <- piston_model(rbind(htc, htc), gallery_gradient = c(0, 0.5),
                       conductivity_slope = c(-3e-4, 0))
  expect_equal(both[1, ], soft[1, ])
  expect_equal(both[2, ], graded[1, ])
  expect_error(piston_model(htc, gallery_gradient = 1.5), "gallery_gradient")
  expect_error(piston_model(htc, conductivity_slope = c(0, 0)), "conductivity_slope")
})
