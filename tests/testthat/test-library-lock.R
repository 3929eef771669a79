# Writers in separate R processes: the lock refuses a second writer, and a
# writer killed part-way leaves the committed library.
#
# The races start child R processes and wait for them (about 70 s in all), so
# they run only when asked: GRIDDY_TEST_RACES=true Rscript tools/run-tests.R
# (or set the variable before testthat::test_local()). The smoke test below
# checks the lock itself in this process and always runs.
skip_on_cran()
skip_if_not_installed("hdf5r")

skip_races <- function() {
  skip_if_not(identical(Sys.getenv("GRIDDY_TEST_RACES"), "true"),
              "lock races run with GRIDDY_TEST_RACES=true")
}

test_that("smoke: a held lock refuses a writer and repair, naming its holder; released, both work", {
  toy <- toy_ar1(n_runs = 30, n_t = 4)
  lib <- toy$library
  file <- withr::local_tempfile(fileext = ".h5")
  write_library(lib_rows(lib, 1:10), file)
  token <- library_lock(file, "library file")
  err <- expect_error(write_library(lib_rows(lib, 11:20), file, append = TRUE),
                      class = "griddy_error_lock")
  expect_match(conditionMessage(err), paste0("the lock .*\\.lock is held by process ",
                                             Sys.getpid(), " on host"))
  expect_error(repair_library(file), class = "griddy_error_lock")
  expect_identical(hdf5_library(file)$n_runs, 10L) # the refused writer wrote nothing
  library_unlock(token)
  expect_false(dir.exists(paste0(file, ".lock")))
  h5 <- write_library(lib_rows(lib, 11:30), file, append = TRUE)
  expect_identical(lib_outputs(h5), lib$y)
  # a dead writer's lock (a process id no longer running) is taken over by
  # the next writer, which repairs the file first (before, it was refused)
  dir.create(lock <- paste0(file, ".lock"))
  writeLines(c("pid: 999999999", paste0("host: ", Sys.info()[["nodename"]]), "since: then"),
             file.path(lock, "owner"))
  extra <- sim_library(data.frame(theta = c(2, 3)), lib$y[1:2, ], t = lib$t)
  leave_uncommitted(file, extra)
  expect_message(h5 <- write_library(extra, file, append = TRUE),
                 "took over the lock of a writer that died.*process 999999999.*keeps its 30 committed runs and the 2 uncommitted",
                 class = "griddy_message_lock_recovered")
  expect_identical(h5$n_runs, 32L)
  expect_false(dir.exists(lock))
  # for an old .rds directory the repair it advises says trust = TRUE
  dir <- withr::local_tempfile(pattern = "griddy-lib-")
  write_rds_chunks(lib, dir, chunk_size = 10)
  token <- library_lock(normalizePath(dir), "library directory")
  on.exit(library_unlock(token), add = TRUE)
  expect_error(repair_library(dir, trust = TRUE), "repair_library\\(.*, trust = TRUE\\)",
               class = "griddy_error_lock")
})

test_that("a lock is stale when its owner is dead, rebooted or its pid reused; never from another host", {
  lock <- withr::local_tempfile()
  dir.create(lock)
  me <- lock_write_owner(lock)
  owner <- lock_owner(lock)
  expect_identical(owner$pid, as.character(Sys.getpid()))
  expect_false(lock_is_stale(owner)) # we are alive
  skip_if(is.na(lock_boot_id()), "no boot id or process start times here (not Linux)")
  expect_false(is.na(owner$start))
  expect_true(lock_is_stale(modifyList(owner, list(start = "1")))) # our pid, reused
  expect_true(lock_is_stale(modifyList(owner, list(boot = "another-boot"))))
  expect_false(lock_is_stale(modifyList(owner, list(host = "elsewhere", pid = "999999999"))))
  # a lock written by an earlier version (no boot, no start) still works
  expect_true(lock_is_stale(list(pid = "999999999", host = lock_host(), since = "then",
                                 boot = NA_character_, start = NA_character_)))
})

test_that("two writers finding the same dead lock: one takes it over, the other is refused", {
  file <- withr::local_tempfile(fileext = ".h5")
  lock <- paste0(file, ".lock")
  dir.create(lock)
  writeLines(c("pid: 999999999", paste0("host: ", lock_host()), "since: then"),
             file.path(lock, "owner"))
  # the other writer is taking it over right now (it holds the breaker)
  dir.create(file.path(lock, "recovering"))
  expect_error(library_lock(file, recover = function() "repaired."), "stale",
               class = "griddy_error_lock")
  unlink(file.path(lock, "recovering"), recursive = TRUE)
  expect_message(token <- library_lock(file, recover = function() "repaired."),
                 "took over the lock.*repaired", class = "griddy_message_lock_recovered")
  expect_identical(lock_owner(lock)$pid, as.character(Sys.getpid()))
  # a late writer that also saw the dead owner now finds a live one
  expect_false(lock_take_stale(lock))
  expect_error(library_lock(file, recover = function() "again."), "Wait for that writer",
               class = "griddy_error_lock")
  library_unlock(token)
  expect_false(dir.exists(lock))
})

test_that("simulate_library() killed (kill -9) in a commit: the resume recovers the lock before simulating", {
  skip_on_cran()
  skip_on_os("windows")
  tt <- seq(0, 1, length.out = 20)
  sim <- function(theta) t(vapply(theta$k, function(k) sin(k * tt), numeric(20)))
  design <- data.frame(k = seq(1, 4, length.out = 60))
  file <- withr::local_tempfile(fileext = ".h5")
  suppressMessages(simulate_library(sim, design[1:20, , drop = FALSE], file, t = tt,
                                    progress = FALSE))
  marker <- tempfile()
  # the child resumes with 20 more rows and stops for good inside its commit,
  # after writing its rows and before the count; then it is killed
  run_child(c("tt <- seq(0, 1, length.out = 20)", # as here, to the bit
              sprintf("sim <- %s", paste(deparse(sim), collapse = "\n")),
              sprintf("design <- %s", paste(deparse(design), collapse = "\n")),
              sprintf(paste0("options(griddy.write_hook = function(s) if (s == 'rows_written') ",
                             "{ file.create(%s); Sys.sleep(120) })"), deparse(marker)),
              sprintf("simulate_library(sim, design[1:40, , drop = FALSE], %s, t = tt, progress = FALSE)",
                      deparse(file))), wait = FALSE)
  wait_for_file(marker, timeout = 120)
  pid <- as.integer(lock_owner(paste0(file, ".lock"))$pid)
  tools::pskill(pid, tools::SIGKILL)
  for (i in 1:100) if (!isTRUE(tools::pskill(pid, 0L))) break else Sys.sleep(0.05)
  expect_true(dir.exists(paste0(file, ".lock"))) # the dead writer's lock stays
  calls <- 0L
  calls_at_recovery <- NA_integer_
  counting <- function(theta) {
    calls <<- calls + nrow(theta)
    sim(theta)
  }
  withCallingHandlers(
    lib <- simulate_library(counting, design, file, t = tt, progress = FALSE),
    griddy_message_lock_recovered = function(m) {
      calls_at_recovery <<- calls
      invokeRestart("muffleMessage")
    })
  expect_identical(calls_at_recovery, 0L) # recovered at open, before any run
  expect_identical(calls, 40L) # the 40 rows not committed, no more
  expect_identical(lib$n_runs, 60L)
  expect_identical(sort(lib$theta$k), design$k)
  expect_false(dir.exists(paste0(file, ".lock")))
})

# R code for a child that appends the sim_library saved in `piece_rds` to
# `file`, with `hook` (code of a function(step)) as the write hook, and records
# "ok" or the error's class in `result`.
append_code <- function(file, piece_rds, result, hook = "NULL") {
  c(sprintf("options(griddy.write_hook = %s)", hook),
    sprintf("piece <- readRDS(%s)", deparse(piece_rds)),
    sprintf("out <- tryCatch({write_library(piece, %s, append = TRUE); 'ok'},",
            deparse(file)),
    "  griddy_error_lock = function(e) 'lock', error = function(e) conditionMessage(e))",
    sprintf("writeLines(out, %s)", deparse(result)))
}

# A hook that, at `step`, touches `marker` and then runs `then`.
hook_code <- function(step, marker, then) {
  sprintf("function(s) if (s == %s) { file.create(%s); %s }", deparse(step), deparse(marker),
          then)
}

save_piece <- function(library) {
  f <- tempfile(fileext = ".rds")
  saveRDS(library, f)
  f
}

test_that("a second writer is refused while the first holds the lock, and readers wait", {
  skip_races()
  toy <- toy_ar1(n_runs = 60, n_t = 8)
  lib <- toy$library
  file <- withr::local_tempfile(fileext = ".h5")
  write_library(lib_rows(lib, 1:20), file)
  marker <- tempfile()
  result <- tempfile()
  run_child(append_code(file, save_piece(lib_rows(lib, 21:40)), result,
                        hook_code("extended", marker, "Sys.sleep(4)")), wait = FALSE)
  wait_for_file(marker)
  err <- expect_error(write_library(lib_rows(lib, 41:60), file, append = TRUE),
                      class = "griddy_error_lock")
  expect_match(conditionMessage(err), "is being written by another writer: the lock .*\\.lock is held by process [0-9]+ on host")
  expect_match(conditionMessage(err), "Wait for that writer to finish")
  # readers are not refused while the writer has the file open (SWMR): they
  # read the committed runs
  expect_silent(h5 <- hdf5_library(file))
  expect_identical(h5$n_runs, 20L)
  wait_for_file(result)
  expect_identical(readLines(result), "ok")
  h5 <- write_library(lib_rows(lib, 41:60), file, append = TRUE)
  expect_identical(lib_outputs(h5), lib$y)
  expect_identical(h5$theta, lib$theta)
})

test_that("two writers started together: one writes, the other is refused, runs never mixed", {
  skip_races()
  toy <- toy_ar1(n_runs = 60, n_t = 8)
  lib <- toy$library
  pieces <- list(a = 21:40, b = 41:60)
  for (trial in 1:2) {
    file <- withr::local_tempfile(fileext = ".h5")
    write_library(lib_rows(lib, 1:20), file)
    go <- tempfile()
    results <- c(a = tempfile(), b = tempfile())
    for (w in names(pieces)) {
      # both wait for `go`, then race for the lock; the winner holds it a while
      code <- append_code(file, save_piece(lib_rows(lib, pieces[[w]])), results[[w]],
                          "function(s) if (s == 'locked') Sys.sleep(1.5)")
      run_child(c(sprintf("while (!file.exists(%s)) Sys.sleep(0.01)", deparse(go)), code),
                wait = FALSE)
    }
    Sys.sleep(4) # both children loaded and waiting
    file.create(go)
    for (r in results) wait_for_file(r)
    Sys.sleep(0.2)
    out <- vapply(results, readLines, "")
    expect_setequal(unname(out), c("ok", "lock"))
    winner <- names(out)[out == "ok"]
    h5 <- hdf5_library(file)
    expect_identical(lib_outputs(h5), lib$y[c(1:20, pieces[[winner]]), ])
    expect_identical(h5$theta$theta, lib$theta$theta[c(1:20, pieces[[winner]])])
    expect_false(dir.exists(paste0(file, ".lock")))
  }
})

test_that("a writer killed part-way leaves the committed library, a stale lock and how to repair", {
  skip_races()
  toy <- toy_ar1(n_runs = 60, n_t = 8)
  lib <- toy$library
  for (step in c("extended", "piece", "rows_written", "committed")) {
    file <- withr::local_tempfile(fileext = ".h5")
    write_library(lib_rows(lib, 1:20), file, chunk_size = 3)
    marker <- tempfile()
    status <- run_child(append_code(file, save_piece(lib_rows(lib, 21:40)), tempfile(),
                                    hook_code(step, marker,
                                              "tools::pskill(Sys.getpid(), tools::SIGKILL)")))
    expect_true(file.exists(marker))
    expect_true(dir.exists(paste0(file, ".lock"))) # the dead writer's lock stays
    committed <- if (step == "committed") 40L else 20L
    if (step == "committed") {
      h5 <- hdf5_library(file)
    } else {
      expect_warning(h5 <- hdf5_library(file), paste0(
        "holds 20 uncommitted run\\(s\\) past its 20 committed runs, left by an append that ",
        "did not finish.*repair_library.*takes over the dead writer's lock"),
        class = "griddy_warning_library")
    }
    expect_identical(lib_outputs(h5), lib$y[seq_len(committed), ])
    expect_identical(posterior_exact(h5, toy$field)$joint,
                     posterior_exact(lib_rows(lib, seq_len(committed)), toy$field)$joint)
    expect_message(
      expect_message(repair_library(file), "took over the lock of a writer that died",
                     class = "griddy_message_lock_recovered"),
      sprintf("holds %d runs", committed))
    expect_silent(hdf5_library(file))
    rest <- setdiff(21:60, seq_len(committed))
    h5 <- write_library(lib_rows(lib, rest), file, append = TRUE)
    expect_identical(lib_outputs(h5), lib$y)
  }
})

test_that("a writer killed at a random moment of a long append leaves a readable library", {
  skip_races()
  set.seed(1)
  n <- 3e5
  theta <- data.frame(a = seq_len(n) / n)
  lib <- sim_library(theta, matrix(as.double(seq_len(n * 30)), n, 30))
  outcomes <- integer(0)
  for (delay in c(0.02, 0.1, 0.25)) {
    file <- withr::local_tempfile(fileext = ".h5")
    write_library(lib_rows(lib, 1:1000), file)
    marker <- tempfile()
    run_child(append_code(file, save_piece(lib_rows(lib, 1001:n)), tempfile(),
                          hook_code("locked", marker, "NULL")), wait = FALSE)
    wait_for_file(marker)
    Sys.sleep(delay)
    pid <- as.integer(lock_owner(paste0(file, ".lock"))$pid)
    tools::pskill(pid, tools::SIGKILL)
    Sys.sleep(0.3)
    h5 <- suppressWarnings(hdf5_library(file))
    expect_true(h5$n_runs %in% c(1000L, n))
    outcomes <- c(outcomes, h5$n_runs)
    expect_identical(lib_outputs(h5, c(1L, h5$n_runs)), lib$y[c(1L, h5$n_runs), ])
    suppressMessages(repair_library(file))
  }
  if (nzchar(Sys.getenv("GRIDDY_SHOW_KILLS"))) message("committed after kills: ", toString(outcomes))
})
