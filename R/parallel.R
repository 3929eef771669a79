# One parallel map under one policy. griddy goes parallel only when the user
# has chosen a future plan with more than one worker (future loaded, so a
# plan can have been set; future.apply installed to map over it); otherwise
# it maps in this process. Asking for workers never loads future: loading it
# costs more than most maps.

# The number of workers of the user's plan, 1 when griddy maps sequentially.
# `scheduled = FALSE` is for work that is cheap next to a scheduler's
# latency (calibrate()'s chains): on a cluster scheduler's plan
# (future.batchtools: Slurm, SGE, ...) it stays in this process, so that
# refine() sends its simulations to the cluster and not its chains.
griddy_workers <- function(scheduled = TRUE) {
  if (!isNamespaceLoaded("future") || !requireNamespace("future.apply", quietly = TRUE)) {
    return(1L)
  }
  if (!scheduled && inherits(future::plan(), "batchtools")) return(1L)
  max(1L, as.integer(future::nbrOfWorkers()))
}

# lapply(X, FUN, ...) on the plan's workers when griddy_workers(scheduled) > 1,
# else in this process. With `seeds` (one integer per element of X), element i
# runs with set.seed(seeds[i]) (R's stream restored after), so a stochastic
# FUN gives the same results under any plan; without, FUN must not draw
# random numbers. Workers need griddy installed.
griddy_map <- function(X, FUN, ..., seeds = NULL, scheduled = TRUE) {
  if (!is.null(seeds)) {
    stopifnot(length(seeds) == length(X))
    fun <- FUN
    FUN <- function(x, seed, ...) with_seed(seed, fun(x, ...))
    X <- Map(list, X, seeds)
    call <- function(pair, ...) FUN(pair[[1]], pair[[2]], ...)
  } else {
    call <- FUN
  }
  if (griddy_workers(scheduled) > 1L) {
    # a worker lost, or a batch job the scheduler reports expired (batchtools
    # may, for a moment, of one that has just finished): the map runs again
    # here, with the same results (each element has its own seed)
    tryCatch(
      future.apply::future_lapply(X, call, ..., future.seed = NULL, future.packages = "griddy"),
      FutureError = function(e) {
        restart_workers()  # a dead worker is not left in the plan
        lapply(X, call, ...)
      })
  } else {
    lapply(X, call, ...)
  }
}
