# diagnose_gap() against the calibrate() it diagnoses, on one system with a
# known gap: outputs a * load * sin(3t) + b * load * cos(2t) over the loads,
# the field data made with the effect "quadratic" (+ s * load^2 * t^2, s =
# 0.2) on. Two candidates: "quadratic" and "scale" (a times 1 + s, which a
# shift of a imitates). The base library holds `n_runs` Latin-hypercube-like
# random runs of (a, b); each candidate holds the same (a, b) with a strength
# drawn from its levels (a quarter of the runs at 0). AR(1) correlation over
# t fitted on the grid rho_t = (0, 0.3, 0.6).
#
# Cases: 10^5 runs x 60 field points (3 loads x 20 t), and 2,000 field
# points (2 loads x 1,000 t) with 5,000 runs. Each: calibrate() with its
# defaults, then diagnose_gap() with its defaults (matched resolution: the
# base and each candidate refined, up to max_runs = 4000 predicted runs
# each) and with max_runs = 0 (the libraries as they are: the diagnosis
# itself). A call still running after GAP_BENCH_LIMIT seconds (default 300)
# is stopped and reported as not finished.
#
# Run from the package root:  Rscript bench/diagnose-gap-speed.R
# GAP_BENCH_SRC: the package source to load (default "."), e.g. an export of
# an older commit with this one's compiled src/; GAP_BENCH_OUT: the results
# stem (default bench/results/diagnose-gap-speed); GAP_BENCH_CASES: "runs",
# "points" or both (default); GAP_BENCH_THREADS: empty (default threads) or a
# count for options(griddy.threads); GAP_BENCH_COMPILE: "1" (default)
# byte-compiles the loaded package's functions before timing, as installing
# it does (load_all() leaves them to R's JIT compiler, which then compiles
# each one inside the first timed call that runs it), "0" leaves them.
src <- Sys.getenv("GAP_BENCH_SRC", ".")
# "installed:<lib>" loads griddy installed in that library (byte-compiled)
installed <- startsWith(src, "installed:")
if (installed) {
  library(griddy, lib.loc = sub("installed:", "", src, fixed = TRUE))
} else {
  pkgload::load_all(src, quiet = TRUE)
}
source("bench/helpers.R")
compiled <- installed || Sys.getenv("GAP_BENCH_COMPILE", "1") == "1"
if (installed) Sys.setenv(GAP_BENCH_COMPILE = "0")
if (compiled && !installed) {
  ns <- asNamespace("griddy")
  for (nm in ls(ns, all.names = TRUE)) {
    f <- get(nm, envir = ns)
    if (!is.function(f) || is.primitive(f)) next
    f <- tryCatch(compiler::cmpfun(f), error = function(e) NULL)
    if (is.null(f)) next
    unlockBinding(nm, ns)
    assign(nm, f, envir = ns)
    lockBinding(nm, ns)
  }
}
threads <- Sys.getenv("GAP_BENCH_THREADS", "")
if (nzchar(threads)) options(griddy.threads = as.integer(threads))
out_stem <- Sys.getenv("GAP_BENCH_OUT", "bench/results/diagnose-gap-speed")
limit <- as.numeric(Sys.getenv("GAP_BENCH_LIMIT", "300"))
cases <- strsplit(Sys.getenv("GAP_BENCH_CASES", "runs,points"), ",")[[1]]

gap_bench_system <- function(n_runs, n_x, n_t, seed = 1) {
  set.seed(seed)
  t <- seq(0, 1, length.out = n_t)
  x <- data.frame(load = seq(1, 3, length.out = n_x))
  sim <- function(a, b, s = 0) {
    s <- rep_len(s, length(a))
    out <- matrix(0, length(a), n_x * n_t)
    for (k in seq_len(n_x)) {
      l <- x$load[k]
      out[, (k - 1) * n_t + seq_len(n_t)] <- outer(a * l, sin(3 * t)) +
        outer(b, cos(2 * t) * l) + outer(s * l^2, t^2)
    }
    out
  }
  theta <- data.frame(a = runif(n_runs, 0.5, 1.5), b = runif(n_runs, 0, 1))
  lib <- sim_library(theta, sim(theta$a, theta$b), x = x, t = t)
  candidate <- function(levels, f) {
    s <- sample(levels, n_runs, replace = TRUE)
    s[seq_len(n_runs %/% 4)] <- 0
    g <- data.frame(a = theta$a, b = theta$b, s = s)
    sim_library(g, f(g$a, g$b, g$s), x = x, t = t)
  }
  candidates <- list(quadratic = candidate(c(0, 0.1, 0.2, 0.3), sim),
                     scale = candidate(c(0, 0.1, 0.2), function(a, b, s) sim(a * (1 + s), b)))
  y <- drop(sim(1, 0.4, 0.2)) + rnorm(n_x * n_t, sd = 0.05)
  field <- field_data(matrix(y, n_x, byrow = TRUE), x = x, t = t)
  list(lib = lib, field = field, candidates = candidates)
}

# measure_call() of f() with a time limit: elapsed NA when it did not finish.
limited_call <- function(f) {
  run <- function() {
    setTimeLimit(elapsed = limit, transient = TRUE)
    on.exit(setTimeLimit(elapsed = Inf))
    f()
  }
  m <- measure_call(tryCatch(run(), error = function(e) {
    structure(list(conditionMessage(e)), class = "unfinished")
  }))
  if (inherits(m$value, "unfinished")) m$elapsed_s <- NA_real_
  m
}

# diagnose_gap() without a progress bar (older code has no `progress`).
diagnose_quietly <- function(fit, candidates, max_runs) {
  args <- list(fit, candidates, seed = 1, max_runs = max_runs)
  if ("progress" %in% names(formals(diagnose_gap))) args$progress <- FALSE
  suppressWarnings(do.call(diagnose_gap, args))
}

run_case <- function(label, n_runs, n_x, n_t) {
  sys <- gap_bench_system(n_runs, n_x, n_t)
  rho_t <- c(0, 0.3, 0.6)
  load <- load_1min()
  cal <- measure_call(suppressWarnings(calibrate(sys$lib, sys$field, rho_t = rho_t, seed = 1,
                                                 progress = FALSE)))
  rows <- list(data.frame(case = label, runs = n_runs, field_points = n_x * n_t,
                          call = "calibrate()", elapsed_s = cal$elapsed_s, cpu_s = cal$cpu_s,
                          other_cores = cal$other_cores, load_before = load,
                          answer = NA_character_))
  for (max_runs in c(4000, 0)) {
    load <- load_1min()
    gap <- limited_call(function() diagnose_quietly(cal$value, sys$candidates, max_runs))
    rows[[length(rows) + 1L]] <- data.frame(
      case = label, runs = n_runs, field_points = n_x * n_t,
      call = paste0("diagnose_gap(max_runs = ", max_runs, ")"), elapsed_s = gap$elapsed_s,
      cpu_s = gap$cpu_s, other_cores = gap$other_cores, load_before = load,
      answer = if (inherits(gap$value, "gap_diagnosis")) gap$value$verdict$answer else
        NA_character_)
  }
  out <- do.call(rbind, rows)
  out$times_calibrate <- out$elapsed_s / out$elapsed_s[1]
  out
}

machine <- machine_note()
res <- list()
if ("runs" %in% cases) res$runs <- run_case("10^5 runs", 1e5, 3, 20)
if ("points" %in% cases) res$points <- run_case("2,000 field points", 5000, 2, 1000)
res <- do.call(rbind, unname(res))
res$code <- Sys.getenv("GAP_BENCH_CODE", system2("git", c("rev-parse", "--short", "HEAD"),
                                                  stdout = TRUE))
res$threads <- if (nzchar(threads)) threads else paste0("default (", griddy_threads(), ")")
res$compiled <- compiled
print(res)
write.csv(res, paste0(out_stem, ".csv"), row.names = FALSE)
tab <- data.frame(case = res$case, call = res$call,
                  `elapsed (s)` = ifelse(is.na(res$elapsed_s), paste0("> ", limit),
                                         fmt3(res$elapsed_s)),
                  `CPU (s)` = fmt3(res$cpu_s),
                  `x calibrate()` = ifelse(is.na(res$times_calibrate), "-",
                                           fmt3(res$times_calibrate)),
                  answer = ifelse(is.na(res$answer), "-", res$answer),
                  check.names = FALSE)
writeLines(c(md_header("diagnose_gap() against its calibrate()", "bench/diagnose-gap-speed.R",
                       machine, res$load_before, res$other_cores), "",
             paste0("Code: ", res$code[1], ". Each case in one process, calls in sequence. ",
                    "Threads: ", res$threads[1], ". Functions byte-compiled before timing: ",
                    compiled, "."), "",
             md_table(tab)), paste0(out_stem, ".md"))
