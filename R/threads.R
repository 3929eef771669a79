#' Threads of griddy's compiled code
#'
#' The quadratic forms \eqn{C_{ig}} that [calibrate()] and [posterior_exact()]
#' precompute, the sorting of their columns for the sampler and the exact
#' posterior over runs run on several threads (OpenMP). `griddy_threads()`
#' says how many.
#'
#' Set the number with `options(griddy.threads = n)`. Without the option,
#' griddy uses the processor's physical cores that other work leaves idle:
#' the logical CPUs less the tasks of other processes that are running or
#' waiting to run (on Linux, from `/proc/loadavg`: the tasks runnable now,
#' and the one-minute load average, each less this process; the larger
#' counts), at most the physical cores, and at least one. Threads that find
#' no idle core do not speed up a computation that reads memory once: they
#' wait for each other (OpenMP's threads spin while they wait), and on a
#' busy machine the default of every logical CPU made the precompute 4.9
#' times slower than one thread. Either way the number is at most
#' * the logical CPUs,
#' * the environment variables `OMP_THREAD_LIMIT` and `OMP_NUM_THREADS`, when
#'   set (CRAN's check machines set `OMP_THREAD_LIMIT` to 2), and
#' * 2 when the environment variable `_R_CHECK_LIMIT_CORES_` is set (to
#'   anything but `"false"`), as `R CMD check --as-cran` does: CRAN allows a
#'   package at most two cores in its checks.
#'
#' A package built without OpenMP runs on one thread. The results do not
#' depend on the number of threads: each \eqn{C_{ig}} is computed the same
#' way, in the same order, whichever thread computes it.
#'
#' When the chunks of a library on disk ([hdf5_library()], [disk_library()])
#' are read on the workers of a parallel [future][future::plan] plan, each
#' worker uses `griddy_threads()` divided by the number of workers.
#'
#' @return The number of threads, an integer >= 1.
#' @examples
#' griddy_threads()
#' old <- options(griddy.threads = 1)
#' griddy_threads()
#' options(old)
#' @export
griddy_threads <- function() {
  limits <- omp_limits_cpp()  # logical CPUs, OMP_THREAD_LIMIT, OMP_NUM_THREADS
  cap <- min(limits, env_count("OMP_THREAD_LIMIT"), env_count("OMP_NUM_THREADS"))
  check <- Sys.getenv("_R_CHECK_LIMIT_CORES_")
  if (nzchar(check) && !identical(tolower(check), "false")) cap <- min(cap, 2L)
  wanted <- getOption("griddy.threads")
  if (is.null(wanted)) return(as.integer(max(1L, min(cap, idle_cores(limits[1])))))
  wanted <- tryCatch(assert_count(wanted, "griddy.threads"), griddy_error = function(e) {
    griddy_abort("Option `griddy.threads` must be a whole number >= 1 (or NULL for the ",
                 "default); received ", paste(format(wanted), collapse = ", "), ".")
  })
  as.integer(max(1L, min(wanted, cap)))
}

# A positive whole number from an environment variable, Inf when unset or
# not one.
env_count <- function(name) {
  v <- suppressWarnings(as.integer(Sys.getenv(name)))
  if (is.na(v) || v < 1L) Inf else v
}

# The threads for each of `workers` parallel workers (a future plan's), so
# that together they use griddy_threads().
threads_per_worker <- function(workers) {
  as.integer(max(1L, griddy_threads() %/% max(1L, workers)))
}

# The default's share of the machine: the physical cores (counted once per
# session), and the logical CPUs (`logical`) less the tasks of other
# processes that are runnable now or on average over the last minute
# (`loadavg`, the line of /proc/loadavg, counts this process too: one task
# less). Without /proc/loadavg, the physical cores.
idle_cores <- function(logical, physical = physical_cores(), loadavg = read_loadavg()) {
  load <- strsplit(loadavg, " ")[[1]]
  if (length(load) < 4L) return(physical)
  runnable <- suppressWarnings(as.numeric(sub("/.*", "", load[4])))
  average <- suppressWarnings(as.numeric(load[1]))
  others <- max(0, runnable - 1, floor(average) - 1, na.rm = TRUE)
  min(physical, logical - others)
}

# The line is read at most once a second (the kernel updates its averages
# every 5 s): one calibrate() asks for the threads several times, and each
# read took 5% of a small fit's call.
read_loadavg <- function(max_age = 1) {
  now <- proc.time()[["elapsed"]]
  if (is.null(thread_cache$loadavg) || now - thread_cache$loadavg_at > max_age) {
    thread_cache$loadavg <- tryCatch(readLines("/proc/loadavg", n = 1L, warn = FALSE)[1],
                                     error = function(e) "", warning = function(w) "")
    thread_cache$loadavg_at <- now
  }
  thread_cache$loadavg
}

physical_cores <- function() {
  if (is.null(thread_cache$physical)) {
    n <- suppressWarnings(parallel::detectCores(logical = FALSE))
    thread_cache$physical <- if (is.na(n) || n < 1L) Inf else n
  }
  thread_cache$physical
}

thread_cache <- new.env(parent = emptyenv())
