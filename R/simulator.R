# Calls of the user's simulator, shared by refine() and simulate_library():
# in chunks, on the future plan's workers when there are any, each finished
# chunk checked and handed on (to be kept, or written to disk) as soon as it
# finishes, so that an interrupt, a killed session or a lost node loses only
# the chunks still running. A chunk whose call fails is run again row by
# row, so only the failing rows are left out.
#
# The simulator contract (the same for both callers): `simulator(theta, ...)`
# receives a data.frame of theta rows (one column per parameter, named as the
# library's) and returns a numeric matrix with one row per theta row, in
# order, and the library's outputs as columns (blocks by x setting; see
# sim_library()). A row with a non-finite output counts as a failed run; an
# error counts as the failure of every row of the call; a matrix of the
# wrong shape is a broken contract and stops everything at once.
#
# Parallel workers. With a plan of more than one worker (griddy_workers()),
# each chunk is a future (future::future()) of its own: at most one per
# worker runs at a time, and a finished one is handed on while the others
# run, in the order they finish. The future's expression calls the simulator
# itself, so future finds the simulator's globals (and packages) as it does
# for any future. A future that cannot deliver its value (a worker that
# died, a Slurm job cancelled: a FutureError) fails its chunk like an error,
# and its rows are run again one by one; a row lost a second time, alone,
# is the culprit (it kills its worker) and fails. After a lost
# worker, once the futures still running have finished, the plan's workers
# are restarted (a dead multisession worker stays dead before future 1.32),
# so no run is sent to a dead worker and the plan is whole when we return.
# Otherwise the chunks run in this process, in order.

# A function(theta, n_out, progress, on_chunk) that runs the user's simulator
# over the rows of theta: calls on_chunk(rows, y) for each finished chunk's
# rows (of theta) and checked outputs, and returns the failed rows, a list of
# list(row, condition). `n_out` may be NULL (the first chunk fixes it).
#
# Each chunk runs with its own seed, that of its first row among seeds drawn
# for every row from R's stream (a row run again alone gets its own), so the
# stream moves on by the same amount under any plan, and a deterministic
# simulator gives the same runs under any plan (a stochastic one, under
# plans with the same number of workers).
simulator_caller <- function(simulator, dots) {
  call <- list(simulator = simulator, dots = dots)
  function(theta, n_out, progress, on_chunk) {
    run_chunks(call, theta, n_out, progress, on_chunk)
  }
}

# One chunk in this process: list(y) or list(error = the condition).
run_job <- function(call, theta_rows, seed) {
  with_seed(seed, tryCatch(list(y = do.call(call$simulator, c(list(theta_rows), call$dots))),
                           error = function(e) list(error = e)))
}

# One chunk as a future, the same work as run_job(). Its expression names the
# simulator, its arguments, the rows and the seed, and future finds their
# globals (a simulator's global variables and functions, its packages) as it
# does for any future.
launch_job <- function(call, theta_rows, seed) {
  simulator <- call$simulator
  dots <- call$dots
  # the label names a scheduler's jobs (squeue shows griddy-simulator)
  future::future(
    withr::with_seed(seed, tryCatch(list(y = do.call(simulator, c(list(theta_rows), dots))),
                                    error = function(e) list(error = e))),
    seed = NULL, label = "griddy-simulator")
}

# A run whose future is lost this many times, the last time alone, is the
# culprit (it kills its worker): it fails; the others lost with it run again.
lost_tries <- 2L

run_chunks <- function(call, theta, n_out, progress, on_chunk) {
  seeds <- sample.int(.Machine$integer.max, nrow(theta))
  state <- new.env(parent = emptyenv())
  state$n_out <- n_out
  state$failed <- list()
  bar <- if (progress) cli::cli_progress_bar("Simulating", total = nrow(theta),
                                             .envir = environment())
  task <- function(rows, lost = 0L) list(rows = rows, seed = seeds[rows[1]], lost = lost)
  # A finished task: its runs handed on, or its rows to run again (returned
  # as tasks), or (one row) recorded as failed.
  finish <- function(done, result) {
    rows <- done$rows
    if (is.null(result$error)) {
      y <- check_simulated(result$y, rows, theta, state$n_out)
      state$n_out <- ncol(y)
      ok <- apply(is.finite(y), 1, all)
      if (any(ok)) on_chunk(rows[ok], y[ok, , drop = FALSE])
      for (r in rows[!ok]) {
        state$failed[[length(state$failed) + 1L]] <- list(row = r, condition = non_finite(theta, r))
      }
    } else if (length(rows) > 1L) {
      # only the failing rows are to fail: each runs alone
      lost <- if (inherits(result$error, "FutureError")) done$lost + 1L else 0L
      return(lapply(rows, task, lost = lost))
    } else if (inherits(result$error, "FutureError") && done$lost + 1L < lost_tries) {
      return(list(task(rows, done$lost + 1L)))
    } else {
      state$failed[[length(state$failed) + 1L]] <- list(row = rows, condition = result$error)
    }
    if (progress) cli::cli_progress_update(inc = length(rows), id = bar)
    list()
  }
  run_tasks(call, theta, lapply(simulator_chunks(nrow(theta)), task), finish)
  state$failed
}

# Runs each task (its theta rows and seed) and calls finish(task, result) as
# each finishes; the tasks finish() returns are run too, after the others.
run_tasks <- function(call, theta, tasks, finish) {
  workers <- griddy_workers()
  if (workers <= 1L) {
    while (length(tasks) > 0L) {
      t1 <- tasks[[1]]
      tasks <- c(tasks[-1], finish(t1, run_job(call, theta[t1$rows, , drop = FALSE], t1$seed)))
    }
    return(invisible())
  }
  running <- list()
  # a scheduler's plan (future.batchtools) has no workers to restart: a job
  # it lost (cancelled, expired) is gone, and the next future is a new job
  restartable <- !inherits(future::plan(), "batchtools")
  lost_worker <- FALSE
  failed_launches <- 0L
  on.exit(if (lost_worker) restart_workers())
  idle <- 0L
  while (length(tasks) > 0L || length(running) > 0L) {
    if (lost_worker && length(running) == 0L) {
      restart_workers()
      lost_worker <- FALSE
    }
    while (!lost_worker && length(running) < workers && length(tasks) > 0L) {
      t1 <- tasks[[1]]
      tasks <- tasks[-1]
      launched <- tryCatch(launch_job(call, theta[t1$rows, , drop = FALSE], t1$seed),
                           FutureError = function(e) e)
      if (!inherits(launched, "FutureError")) {
        failed_launches <- 0L
        running[[length(running) + 1L]] <- list(task = t1, future = launched)
        next
      }
      # sent to a dead worker: not the task's fault, it waits for the
      # restart (unless launches keep failing on fresh workers)
      lost_worker <- restartable
      failed_launches <- failed_launches + 1L
      tasks <- if (failed_launches <= lost_tries) c(list(t1), tasks) else
        c(tasks, finish(t1, list(error = launched)))
    }
    if (length(running) == 0L) next
    done <- vapply(running, function(r) {
      tryCatch(future::resolved(r$future), error = function(e) TRUE)
    }, logical(1))
    if (!any(done)) {
      # each poll of a scheduler's future asks the scheduler: slow down
      # while nothing finishes
      idle <- idle + 1L
      Sys.sleep(min(1, 0.02 * 1.3^idle))
      next
    }
    idle <- 0L
    for (r in running[done]) {
      result <- tryCatch(future::value(r$future), error = function(e) list(error = e))
      if (inherits(result$error, "FutureError") && restartable) lost_worker <- TRUE
      tasks <- c(tasks, finish(r$task, result))
    }
    running <- running[!done]
  }
  invisible()
}

# The plan set again, its workers started afresh: a worker that died is
# replaced (future's own resetWorkers() covers only multicore before 1.32).
restart_workers <- function() {
  # (plan() reads its argument unevaluated: a variable, not a call)
  strategies <- future::plan("list")
  tryCatch(future::plan(strategies, .skip = FALSE), error = function(e) NULL)
  invisible()
}

# Chunks of rows: about four per worker, and at least ten for the progress
# bar, so a slow run holds up little (and an interrupt loses little).
simulator_chunks <- function(n) {
  k <- min(n, max(10L, 4L * griddy_workers()))
  if (k < 2L) return(list(seq_len(n)))  # cut() needs two intervals
  unname(split(seq_len(n), cut(seq_len(n), k, labels = FALSE)))
}

# The shape of a chunk's outputs; non-finite rows are left to the caller.
check_simulated <- function(y, rows, theta, n_out) {
  if (is.numeric(y) && is.null(dim(y)) && length(rows) == 1L) y <- matrix(y, 1L)
  if (!is.matrix(y) || !is.numeric(y) || nrow(y) != length(rows) ||
      (!is.null(n_out) && ncol(y) != n_out)) {
    griddy_abort("`simulator` must return a numeric matrix with one row per theta row and ",
                 if (is.null(n_out)) "one column per output" else
                   paste0(n_out, " columns (the library's outputs)"), "; for rows ",
                 show_some(rows), " it returned ",
                 if (is.matrix(y)) paste0("a ", nrow(y), " x ", ncol(y), " ", typeof(y),
                                          " matrix") else class(y)[1], ".", class = "shape")
  }
  storage.mode(y) <- "double"
  unname(y)
}

non_finite <- function(theta, row) {
  rlang::error_cnd(c("griddy_error_numeric", "griddy_error"),
                   message = paste0("`simulator` returned non-finite outputs for theta ",
                                    show_theta(theta, row), "."))
}

show_theta <- function(theta, row) {
  paste0(names(theta), " = ", format(unlist(theta[row, ]), digits = 4), collapse = ", ")
}

# The failed rows as one line each: theta and the simulator's message.
failed_lines <- function(failed, theta) {
  vapply(failed, function(f) {
    paste0("row ", f$row, " (", show_theta(theta, f$row), "): ",
           condition_text(f$condition))
  }, "")
}

# A condition's message as one string; a condition without one (a NULL or
# empty message, as some packages signal) is named by its classes instead.
condition_text <- function(cnd) {
  msg <- tryCatch(conditionMessage(cnd), error = function(e) NULL)
  msg <- if (is.character(msg)) trimws(paste(msg, collapse = " ")) else ""
  if (nzchar(msg)) return(msg)
  paste0("a condition of class ", paste(class(cnd), collapse = "/"), " with no message")
}

# Simulates the rows of theta_new, keeping what finishes: list(rows = the
# rows simulated, in order, y = their outputs, failed = the failed rows (see
# run_chunks()), failure = NULL or the condition that stopped the
# simulator: an interrupt, a broken contract, or an error naming the failed
# rows, with the class of the first failure). `keep(theta, y)` is called
# with each finished chunk first (to write it to disk).
simulate_runs <- function(simulator, theta_new, n_out, progress, keep = NULL) {
  done <- new.env(parent = emptyenv())
  done$rows <- integer()
  done$y <- list()
  on_chunk <- function(rows, y) {
    if (!is.null(keep)) keep(theta_new[rows, , drop = FALSE], y)
    done$rows <- c(done$rows, rows)
    done$y[[length(done$y) + 1L]] <- y
  }
  failed <- list()
  failure <- tryCatch({
    failed <- simulator(theta_new, n_out, progress, on_chunk)
    if (length(failed) > 0L) simulation_failure(failed, theta_new) else NULL
  }, error = function(e) e, interrupt = function(e) e)
  y <- if (length(done$y) > 0L) do.call(rbind, done$y) else matrix(0, 0, n_out)
  in_order <- order(done$rows)
  list(rows = done$rows[in_order], y = y[in_order, , drop = FALSE], failed = failed,
       failure = failure)
}

# One error for the failed rows, with the griddy class of the first failure.
simulation_failure <- function(failed, theta) {
  first <- failed[[1]]$condition
  lines <- failed_lines(failed, theta)
  rlang::error_cnd(
    unique(c(grep("^griddy_error_", class(first), value = TRUE), "griddy_error")),
    message = paste0("The simulator failed on ", length(failed), " run(s): ",
                     paste(utils::head(lines, 5L), collapse = "; "),
                     if (length(lines) > 5L) "; ..."))
}
