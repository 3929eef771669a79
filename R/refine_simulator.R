# refine()'s calls of the user's simulator: in chunks, on the future plan's
# workers when there are any (griddy_map()), each chunk's outputs checked
# and handed on as soon as its wave finishes, so that a failure or an
# interrupt loses only the chunks still running.

# A function(theta, n_out, progress, on_chunk) that runs the user's simulator
# over the rows of theta and calls on_chunk(rows, y) with each finished
# chunk's rows (of theta) and checked outputs, in order.
#
# Each chunk runs with its own seed, that of its first row among seeds drawn
# for every row from R's stream, so the stream moves on by the same amount
# under any plan, and a deterministic simulator gives the same library under
# any plan (a stochastic one, under plans with the same number of workers).
simulator_caller <- function(simulator, dots) {
  force(simulator)
  function(theta, n_out, progress, on_chunk) {
    chunks <- simulator_chunks(nrow(theta))
    seeds <- sample.int(.Machine$integer.max, nrow(theta))
    bar <- if (progress) cli::cli_progress_bar("Simulating", total = nrow(theta),
                                               .envir = environment())
    call_chunk <- function(rows) {
      do.call(simulator, c(list(theta[rows, , drop = FALSE]), dots))
    }
    per_wave <- griddy_workers()
    for (wave in split(seq_along(chunks), (seq_along(chunks) - 1L) %/% per_wave)) {
      out <- griddy_map(chunks[wave], call_chunk,
                        seeds = seeds[vapply(chunks[wave], `[`, 1L, 1L)])
      for (j in seq_along(wave)) {
        rows <- chunks[[wave[j]]]
        on_chunk(rows, check_simulated(out[[j]], rows, theta, n_out))
      }
      if (progress) cli::cli_progress_update(inc = sum(lengths(chunks[wave])), id = bar)
    }
    invisible()
  }
}

# Chunks of rows: about four per worker, and at least ten for the progress
# bar, so a slow run holds up little (and an interrupt loses little).
simulator_chunks <- function(n) {
  k <- min(n, max(10L, 4L * griddy_workers()))
  if (k < 2L) return(list(seq_len(n)))  # cut() needs two intervals
  unname(split(seq_len(n), cut(seq_len(n), k, labels = FALSE)))
}

check_simulated <- function(y, rows, theta, n_out) {
  if (is.numeric(y) && is.null(dim(y)) && length(rows) == 1L) y <- matrix(y, 1L)
  if (!is.matrix(y) || !is.numeric(y) || nrow(y) != length(rows) || ncol(y) != n_out) {
    griddy_abort("`simulator` must return a numeric matrix with one row per theta row and ",
                 n_out, " columns (the library's outputs); for rows ",
                 show_some(rows), " it returned ",
                 if (is.matrix(y)) paste0("a ", nrow(y), " x ", ncol(y), " ", typeof(y),
                                          " matrix") else class(y)[1], ".", class = "shape")
  }
  if (!all(is.finite(y))) {
    bad <- rows[!apply(is.finite(y), 1, all)]
    griddy_abort("`simulator` returned non-finite outputs for theta ",
                 paste0(names(theta), " = ", format(unlist(theta[bad[1], ]), digits = 4),
                        collapse = ", "), " (", length(bad), " run(s)).", class = "numeric")
  }
  storage.mode(y) <- "double"
  unname(y)
}

# Simulates the rows of theta_new, keeping what finishes: list(rows = the
# rows simulated, y = their outputs, failure = NULL or the condition (an
# error or an interrupt) that stopped the simulator). `keep(rows, y)` is
# called with each finished chunk first (to write it to disk).
simulate_runs <- function(simulator, theta_new, n_out, progress, keep = NULL) {
  done <- new.env(parent = emptyenv())
  done$rows <- integer()
  done$y <- list()
  on_chunk <- function(rows, y) {
    force(y)  # a chunk counts once its outputs are checked
    if (!is.null(keep)) keep(theta_new[rows, , drop = FALSE], y)
    done$rows <- c(done$rows, rows)
    done$y[[length(done$y) + 1L]] <- y
  }
  failure <- tryCatch({
    simulator(theta_new, n_out, progress, on_chunk)
    NULL
  }, error = function(e) e, interrupt = function(e) e)
  list(rows = done$rows, y = if (length(done$y) > 0L) do.call(rbind, done$y) else
         matrix(0, 0, n_out), failure = failure)
}
