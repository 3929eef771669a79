test_that("refine(file =) keeps every finished run on disk and resumes from it in a new session", {
  skip_if_not_installed("hdf5r")
  toy <- refine_toy()
  file <- withr::local_tempfile(fileext = ".h5")
  withr::defer(unlink(paste0(file, ".rounds.csv")))
  s <- refine_sim_failing(fail_at = 14L)
  e <- tryCatch(refine(toy$fit, s$sim, max_runs = 400, runs_per_round = 20, file = file,
                       seed = 1), error = function(e) e)
  expect_s3_class(e, "griddy_error_simulator")
  expect_match(conditionMessage(e), file, fixed = TRUE)
  on_disk <- hdf5_library(file)
  expect_equal(lib_theta(on_disk)$k, s$seen$k)
  expect_equal(lib_outputs(on_disk), refine_sim(lib_theta(on_disk)))
  # side files damaged or lost after a kill: named, nothing resumed or simulated
  table <- paste0(file, ".rounds.csv")
  damaged <- list(row_lost = function(l) l[-3],
                  value_changed = function(l) replace(l, 2, paste0(l[2], "1")),
                  no_checksum = function(l) l[-length(l)], deleted = function(l) NULL)
  for (how in names(damaged)) {
    copy <- file.path(withr::local_tempdir(), "copy.h5")
    file.copy(file, copy)
    lines <- damaged[[how]](readLines(table))
    if (!is.null(lines)) writeLines(lines, paste0(copy, ".rounds.csv"))
    s_how <- refine_sim_failing()
    expect_error(refine(toy$fit, s_how$sim, max_runs = 400, runs_per_round = 20, file = copy,
                        seed = 2),
                 if (how == "deleted") "is missing" else "is damaged",
                 class = "griddy_error_damaged", info = how)
    expect_null(s_how$seen)
  }
  # a new session has only the fit it started from: the file's runs are taken,
  # not simulated again
  s2 <- refine_sim_failing()
  ref <- refine(toy$fit, s2$sim, max_runs = 400, runs_per_round = 20, file = file, seed = 2)
  expect_false(any(s2$seen$k %in% s$seen$k))
  expect_true(all(s$seen$k %in% lib_theta(ref$library)$k))
  # the prior weights see the file's rounds as they were
  expect_equal(sapply(lib_rounds(ref$library), `[[`, "n")[1:2], c(20, 19))
  expect_equal(lib_rounds(ref$library)[[1]]$box, lib_rounds(e$fit$library)[[1]]$box,
               ignore_attr = TRUE)
  # and the file holds every run of the refinement
  expect_setequal(lib_theta(hdf5_library(file))$k, lib_theta(ref$library)$k[-(1:7)])
  expect_equal(ref$refinement$reason, "resolved")
})

test_that("after an interrupt, refine(e$fit, file =) takes nothing twice", {
  skip_if_not_installed("hdf5r")
  toy <- refine_toy()
  file <- withr::local_tempfile(fileext = ".h5")
  withr::defer(unlink(paste0(file, ".rounds.csv")))
  s <- refine_sim_failing(fail_at = 13L, fail = signal_interrupt)
  e <- tryCatch(refine(toy$fit, s$sim, max_runs = 400, runs_per_round = 20, file = file,
                       seed = 1), error = function(e) e)
  expect_s3_class(e, "griddy_error_interrupted")
  expect_equal(lib_n_runs(hdf5_library(file)), 24L)
  s2 <- refine_sim_failing()
  ref <- refine(e$fit, s2$sim, max_runs = 400, runs_per_round = 20, file = file, seed = 2)
  k <- lib_theta(ref$library)$k
  expect_false(anyDuplicated(k) > 0)
  expect_false(any(s2$seen$k %in% s$seen$k))
})

test_that("refine(file =) refuses a file without a simulator and a file of other runs", {
  skip_if_not_installed("hdf5r")
  toy <- refine_toy()
  file <- withr::local_tempfile(fileext = ".h5")
  expect_error(refine(toy$fit, file = file), class = "griddy_error_input")
  other <- sim_library(data.frame(a = 1:3 + 0), matrix(stats::rnorm(120), 3), t = toy$lib$t)
  write_library(other, file)
  expect_error(refine(toy$fit, refine_sim, file = file, max_runs = 20),
               class = "griddy_error_library")
})

test_that("refine(file =) refuses a file of other outputs, naming the difference", {
  skip_if_not_installed("hdf5r")
  toy <- refine_toy()
  theta <- data.frame(k = c(1.1, 2.2, 3.3))
  others <- list(
    "its outputs are at t = " = sim_library(theta, refine_sim(theta), t = toy$lib$t * 2),
    "its outputs are at t = .*\\(20 per x setting\\)" =
      sim_library(theta, refine_sim(theta)[, 1:20], t = toy$lib$t[1:20]),
    "its x settings are" = sim_library(theta, cbind(refine_sim(theta), refine_sim(theta)),
                                       x = data.frame(load = 1:2), t = toy$lib$t))
  for (what in names(others)) {
    file <- file.path(withr::local_tempdir(), "other.h5")
    write_library(others[[what]], file)
    s <- refine_sim_failing()
    expect_error(refine(toy$fit, s$sim, file = file, max_runs = 20, seed = 1), what,
                 class = "griddy_error_library")
    expect_null(s$seen)
  }
})

test_that("a proposal round (four parameters) on disk resumes with the same proposal", {
  skip_if_not_installed("hdf5r")
  toy <- linear4_toy()
  file <- withr::local_tempfile(fileext = ".h5")
  withr::defer(unlink(paste0(file, c(".rounds.csv", ".proposals.csv"))))
  done <- 0L
  failing <- function(theta) {
    done <<- done + nrow(theta)
    if (done > 1200L) stop("the solver diverged")
    linear4_sim(theta)
  }
  e <- tryCatch(refine(toy$fit, failing, max_runs = 2000, runs_per_round = 500, file = file,
                       seed = 1), error = function(e) e)
  expect_s3_class(e, "griddy_error_simulator")
  kept <- lib_rounds(e$fit$library)
  expect_false(is.null(kept[[2]]$proposal))
  # its table of proposals garbled or lost: named, not resumed
  proposals <- paste0(file, ".proposals.csv")
  for (how in c("garbled", "deleted")) {
    copy <- file.path(withr::local_tempdir(), "copy.h5")
    file.copy(c(file, paste0(file, ".rounds.csv")), paste0(copy, c("", ".rounds.csv")))
    lines <- readLines(proposals)
    if (how == "garbled") {
      lines[2] <- sub("^([^,]*,[^,]*,[^,]*,[^,]*,[^,]*,[^,]*,)[^,]*", "\\10.5", lines[2])
      writeLines(lines, paste0(copy, ".proposals.csv"))
    }
    expect_error(refine(toy$fit, linear4_sim, max_runs = 1, file = copy, seed = 2),
                 class = "griddy_error_damaged", info = how)
  }
  ref <- suppressWarnings(refine(toy$fit, linear4_sim, max_runs = 1, file = file, seed = 2))
  resumed <- lib_rounds(ref$library)[seq_along(kept)]
  expect_identical(vapply(resumed, `[[`, integer(1), "n"), vapply(kept, `[[`, integer(1), "n"))
  expect_equal(resumed[[2]]$proposal, kept[[2]]$proposal, tolerance = 1e-12, ignore_attr = TRUE)
  # the design density: the kept rounds' as before, plus the new round's
  theta <- lib_theta(e$fit$library)
  new <- lib_rounds(ref$library)[-seq_along(kept)]
  extra <- Reduce(`+`, lapply(new, function(r) {
    if (is.null(r$proposal)) 0 else r$n * proposal_density(r$proposal, theta)
  }), 0)
  expect_equal(design_density(ref$library, theta), design_density(e$fit$library, theta) + extra)
})
