# Shared by the bench/*.R scripts: timing, peak memory, machine load, the
# thesis's three-parameter test library and the plain-R Appendix A loop.

time_it <- function(expr) {
  gc()
  t0 <- proc.time()[["elapsed"]]
  force(expr)
  proc.time()[["elapsed"]] - t0
}

# One pass over memory as a plain C++ read loop: griddy's unexported
# memory_pass_cpp() (src/memory_pass.cpp), or for a griddy without it (the
# old code of a side-by-side run) the same source compiled here. R's sum()
# reads about 3 times slower (it adds in long double), so passes counted in
# sum() understate how many times a computation reads its memory.
read_loop_fn <- function() {
  fn <- get0("memory_pass_cpp", envir = asNamespace("griddy"), inherits = FALSE)
  if (!is.null(fn)) return(fn)
  env <- new.env()
  Rcpp::sourceCpp("src/memory_pass.cpp", env = env)
  env$memory_pass_cpp
}

# Peak resident memory of this R process so far, in MB (Linux).
peak_mb <- function() {
  s <- readLines("/proc/self/status")
  as.numeric(sub("[^0-9]*([0-9]+).*", "\\1", grep("^VmHWM", s, value = TRUE))) / 1024
}

# Current resident memory in MB, and a reset of the peak (Linux >= 4.0), so
# that a later peak_mb() measures what came after.
rss_mb <- function() {
  s <- readLines("/proc/self/status")
  as.numeric(sub("[^0-9]*([0-9]+).*", "\\1", grep("^VmRSS", s, value = TRUE))) / 1024
}
reset_peak <- function() {
  invisible(try(writeLines("5", "/proc/self/clear_refs"), silent = TRUE))
}

machine_note <- function() {
  paste0(R.version.string, "; ", parallel::detectCores(), " cores; load average ",
         trimws(sub(".*load average: ", "", system("uptime", intern = TRUE))))
}

# A smooth three-parameter response at `n_points` locations: stands in for the
# piston simulator (the sampler's cost does not depend on what made the runs).
thesis_response <- function(h, locations) {
  outer(500 / sqrt(1 + h[, 1] / 1000), exp(-locations)) +
    outer(300 / sqrt(1 + h[, 2] / 1000), sin(3 * locations)) +
    outer(200 / sqrt(1 + h[, 3] / 1000), locations^2)
}

# Runs on a full grid of n_per_dim values per parameter (the thesis's ranges),
# or `n_runs` random runs.
thesis_theta <- function(n_per_dim = NULL, n_runs = NULL, seed = 1) {
  if (!is.null(n_per_dim)) {
    return(expand.grid(h1 = seq(13.85, 11984.70, length.out = n_per_dim),
                       h2 = seq(8.61, 11977.45, length.out = n_per_dim),
                       h3 = seq(35.33, 12002.49, length.out = n_per_dim)))
  }
  set.seed(seed)
  data.frame(h1 = runif(n_runs, 13.85, 11984.70), h2 = runif(n_runs, 8.61, 11977.45),
             h3 = runif(n_runs, 35.33, 12002.49))
}

# `n_runs` random runs (thesis_theta()) and their outputs at `n_points`
# locations on [0, 1], built in blocks of 10^5 runs (no full-size temporaries).
thesis_runs <- function(n_runs, n_points) {
  theta <- thesis_theta(n_runs = n_runs)
  locations <- seq(0, 1, length.out = n_points)
  y <- matrix(0, n_runs, n_points)
  for (from in seq(1, n_runs, by = 1e5)) {
    rows <- from:min(n_runs, from + 1e5 - 1)
    y[rows, ] <- thesis_response(as.matrix(theta[rows, ]), locations)
  }
  list(theta = theta, y = y, t = locations)
}

thesis_field <- function(n_points, seed = 1) {
  locations <- seq(0, 1, length.out = n_points)
  set.seed(seed)
  drop(thesis_response(cbind(1000, 3000, 2000), locations)) + rnorm(n_points, sd = sqrt(0.4))
}

# The thesis's Appendix A loop in plain R, vectorised over runs with a loop
# over iterations: given the quadratic forms C (runs x grid points) and the
# log-determinants, draw theta | tau, rho by inverse CDF over all runs, then
# tau | theta, rho, then rho | theta, tau. Returns the kept runs, with the
# kept grid points as attribute `grid_point`.
thesis_plain_r <- function(C, logdet, n, n_iter, burn_in, a = 1e-9, b = 1e-9) {
  C <- as.matrix(C)
  G <- ncol(C)
  tau <- 1
  g <- 1L
  keep <- integer(n_iter - burn_in)
  keep_grid <- integer(n_iter - burn_in)
  for (it in seq_len(n_iter)) {
    lp <- -tau / 2 * C[, g]
    p <- exp(lp - max(lp))
    cdf <- cumsum(p) / sum(p)
    run <- which(cdf > runif(1))[1]
    tau <- rgamma(1, a + n / 2, b + C[run, g] / 2)
    if (G > 1L) {
      lw <- -logdet / 2 - tau / 2 * C[run, ]
      pw <- exp(lw - max(lw))
      g <- which(cumsum(pw) / sum(pw) > runif(1))[1]
    }
    if (it > burn_in) {
      keep[it - burn_in] <- run
      keep_grid[it - burn_in] <- g
    }
  }
  attr(keep, "grid_point") <- keep_grid
  keep
}

# Plain-R quadratic forms with R_x = I and an AR(1) R_t per rho_t (thesis
# Appendix B), vectorised over runs: innovations of each x block, squared.
plain_quad_forms <- function(Y, y, n_x, t, rho_t) {
  n_t <- length(t)
  E <- matrix(y, nrow(Y), ncol(Y), byrow = TRUE) - Y
  s <- (t - min(t)) / (max(t) - min(t))
  out <- matrix(0, nrow(Y), length(rho_t))
  logdet <- numeric(length(rho_t))
  for (g in seq_along(rho_t)) {
    phi <- if (rho_t[g] == 0) rep(0, n_t - 1) else rho_t[g]^diff(s)
    for (k in seq_len(n_x)) {
      B <- E[, (k - 1) * n_t + seq_len(n_t)]
      W <- (B[, -1] - B[, -n_t] * rep(phi, each = nrow(B))) *
        rep(1 / sqrt(1 - phi^2), each = nrow(B))
      out[, g] <- out[, g] + B[, 1]^2 + rowSums(W^2)
    }
    logdet[g] <- n_x * sum(log1p(-phi^2))
  }
  list(C = out, logdet = logdet)
}

# Plain-R quadratic forms over a grid of one rho per x column (thesis
# Appendix A): every combination of the columns' grids (as its lines 114-118
# assemble them; the first column varies fastest, as in rho_grid()),
# R_x[k, l] = prod_j rho_j^|x_kj - x_lj| (eq. 5 as a product, which is
# calibrate()'s `x_power = 1`; x scaled to [0, 1] per column as griddy does),
# then C = (y - g)' R_x^-1 (y - g) for every run, vectorised over runs, and
# log|R_x|.
plain_quad_forms_x <- function(Y, y, x, rho_x) {
  E <- matrix(y, nrow(Y), ncol(Y), byrow = TRUE) - Y
  dist <- lapply(x, function(v) {
    span <- max(v) - min(v)
    s <- if (span > 0) (v - min(v)) / span else v * 0
    abs(outer(s, s, "-"))
  })
  combos <- expand.grid(rho_x, KEEP.OUT.ATTRS = FALSE)
  C <- matrix(0, nrow(Y), nrow(combos))
  logdet <- numeric(nrow(combos))
  for (g in seq_len(nrow(combos))) {
    R <- Reduce(`*`, Map(function(rho, d) rho^d, unlist(combos[g, ]), dist))  # 0^0 = 1
    C[, g] <- rowSums((E %*% solve(R)) * E)
    logdet[g] <- determinant(R)$modulus
  }
  list(C = C, logdet = logdet)
}

# ---- implementations side by side, each in its own R process ------------------

# The 54-point piston case of chapters 3-4 as plain data, so that every griddy
# version reads the same: the library with `per_dim` values per coefficient
# (27 locations x 2 operating conditions; x = r, z, condition) and the field
# piston_field_data(54, discrepancy = TRUE, seed = 2023). Needs griddy.
piston_case_inputs <- function(per_dim) {
  secs <- time_it(lib <- griddy::piston_library(per_dim, locations = 1:27,
                                                condition = c("full", "part")))
  field <- griddy::piston_field_data(54, discrepancy = TRUE, seed = 2023)
  stopifnot(isTRUE(all.equal(field$x, lib$x)))
  list(theta = lib$theta, y = lib$y, x = lib$x, field_y = drop(field$y), build_s = secs)
}

# The library and field of piston_case_inputs() for the griddy loaded.
case_library <- function(inputs) griddy::sim_library(inputs$theta, inputs$y, x = inputs$x)
case_field <- function(inputs) griddy::field_data(inputs$field_y, x = inputs$x)

# The library holding griddy as on main before issue 15 (commit c18971b),
# installed from this git repository on first use (about 1-3 minutes).
old_griddy_lib <- function(lib = Sys.getenv("GRIDDY_OLD_LIB", "/tmp/lib-griddy-old"),
                           commit = "c18971b") {
  if (!file.exists(file.path(lib, "griddy", "DESCRIPTION"))) {
    message("Installing griddy at ", commit, " into ", lib)
    src <- tempfile("griddy-src-")
    dir.create(src)
    dir.create(lib, showWarnings = FALSE, recursive = TRUE)
    if (system(paste("git archive", commit, "| tar -x -C", shQuote(src))) != 0 ||
        system2(file.path(R.home("bin"), "R"),
                c("CMD", "INSTALL", "--preclean", "-l", shQuote(lib), shQuote(src))) != 0) {
      stop("Could not install griddy ", commit, " into ", lib)
    }
    unlink(src, recursive = TRUE)
  }
  lib
}

# The library of the code under test: GRIDDY_NEW_LIB, or "" for the griddy
# the default library paths (and R_LIBS) give.
new_griddy_lib <- function() Sys.getenv("GRIDDY_NEW_LIB", "")

# Thread counts to run the new code with (GRIDDY_NEW_THREADS, e.g. "1,2"; set
# as option griddy.threads); NA alone: the package's default.
new_griddy_threads <- function() {
  v <- Sys.getenv("GRIDDY_NEW_THREADS", "")
  if (nzchar(v)) as.integer(strsplit(v, ",")[[1]]) else NA_integer_
}

# Run an R script in a fresh process whose griddy comes from `lib` ("": the
# default library paths), with extra environment variables `env`
# ("NAME=value"); stop if it fails.
run_child <- function(script, args, lib = "", env = character()) {
  env <- c(if (nzchar(lib)) paste0("R_LIBS=", lib), env)
  status <- system2(file.path(R.home("bin"), "Rscript"), c(script, args), env = env)
  if (status != 0) stop(script, " ", paste(args, collapse = " "), " failed (status ", status, ")")
}

# In a child: set option griddy.threads from GRIDDY_THREADS, and describe the
# griddy loaded: version, library, the thread option and the threads it
# gives (griddy_threads(); NA for a griddy without it, which runs on one).
griddy_child_setup <- function() {
  threads <- Sys.getenv("GRIDDY_THREADS", "")
  if (nzchar(threads)) options(griddy.threads = as.integer(threads))
  threads_fn <- get0("griddy_threads", envir = asNamespace("griddy"), inherits = FALSE)
  data.frame(griddy_version = format(utils::packageVersion("griddy")),
             griddy_lib = dirname(find.package("griddy")),
             threads_option = if (is.null(getOption("griddy.threads"))) "default" else
               format(getOption("griddy.threads")),
             griddy_threads = if (is.null(threads_fn)) NA_integer_ else threads_fn())
}

# The threads column of a results page: the option as set, the threads
# griddy_threads() gives, and the OS threads of the process after the call.
threads_label <- function(option, used, os) {
  paste0(option, " -> ", ifelse(is.na(used), "-", used), " (", os, " OS)")
}

# One-minute load average, and whether other work shared the machine (load
# above 1 before a single-process benchmark starts).
load_1min <- function() as.numeric(strsplit(readLines("/proc/loadavg"), " ")[[1]][1])

# Threads of this process now (OpenMP keeps its pool after a parallel region).
os_threads <- function() {
  s <- readLines("/proc/self/status")
  as.integer(sub("[^0-9]*([0-9]+).*", "\\1", grep("^Threads", s, value = TRUE)))
}

# CPU seconds the whole machine has been busy since boot (Linux /proc/stat:
# user, nice, system, irq, softirq and steal time over all cores).
machine_busy_s <- function() {
  ticks <- as.numeric(strsplit(trimws(readLines("/proc/stat", n = 1L)), " +")[[1]][-1])
  sum(ticks[c(1:3, 6:8)]) / 100  # USER_HZ is 100 on Linux
}

# The cores other processes kept busy since `start` (other_work_start()): the
# machine's busy time less this process's, over the elapsed time; 0 on an
# otherwise idle machine. NA over less than a second (the counters tick in
# hundredths of a second).
other_work_start <- function() list(busy = machine_busy_s(), time = proc.time())
other_cores_since <- function(start) {
  t <- proc.time() - start$time
  if (t[["elapsed"]] < 1) return(NA_real_)
  own <- t[["user.self"]] + t[["sys.self"]]
  max(0, (machine_busy_s() - start$busy - own) / t[["elapsed"]])
}

# Evaluate `expr`, measuring elapsed and CPU seconds (all threads of this
# process), the peak resident memory during it above the memory before it
# (peak reset first), the absolute peak, the threads afterwards, and the
# cores other processes kept busy meanwhile (other_cores_since()).
measure_call <- function(expr) {
  gc()
  reset_peak()
  before <- rss_mb()
  others <- other_work_start()
  t0 <- proc.time()
  value <- force(expr)
  t <- proc.time() - t0
  list(value = value, elapsed_s = t[["elapsed"]], cpu_s = t[["user.self"]] + t[["sys.self"]],
       rss_before_mb = before, peak_extra_mb = peak_mb() - before, peak_mb = peak_mb(),
       os_threads = os_threads(), other_cores = other_cores_since(others))
}

# Evaluate `expr`, muffling warnings and returning their classes (first
# class of each, unique) as attribute "warnings" of the value.
with_warning_classes <- function(expr) {
  classes <- character()
  value <- withCallingHandlers(expr, warning = function(w) {
    classes <<- union(classes, class(w)[1])
    invokeRestart("muffleWarning")
  })
  attr(value, "warnings") <- paste(classes, collapse = " ")
  value
}

# Largest elementwise relative difference between two tables written with
# writeBin() (same shape, doubles), read in blocks; NA if the sizes differ.
max_rel_diff_bin <- function(a, b, block = 1e7) {
  if (!file.exists(a) || !file.exists(b) || file.size(a) != file.size(b)) return(NA_real_)
  ca <- file(a, "rb")
  cb <- file(b, "rb")
  on.exit({
    close(ca)
    close(cb)
  })
  worst <- 0
  repeat {
    va <- readBin(ca, "double", block)
    vb <- readBin(cb, "double", block)
    if (length(va) == 0L) break
    worst <- max(worst, abs(va - vb) / pmax(abs(vb), .Machine$double.xmin))
  }
  worst
}

# Largest |z| of the difference of two posterior means over parameters,
# z = (mean_a - mean_b) / sqrt(mcse_a^2 + mcse_b^2) (tables with parameter,
# mean, mcse; the mcse of a parameter whose draws sit on one value is NA and
# counts as 0); Inf for different means when both sit on one value.
max_mean_z <- function(a, b) {
  m <- merge(a, b, by = "parameter")
  se <- sqrt(pmax(0, m$mcse.x, na.rm = TRUE)^2 + pmax(0, m$mcse.y, na.rm = TRUE)^2)
  diff <- abs(m$mean.x - m$mean.y)
  max(ifelse(se > 0, diff / se, ifelse(diff == 0, 0, Inf)))
}

# The opening lines of a results page: title, script, date, machine, and
# whether other work shared it: the most cores other processes kept busy
# during a timed call (other_cores_since(); above 0.2, the machine was
# shared). The one-minute load average before each process is reported
# too, but it counts the benchmark's own previous process, so it is not the
# test.
md_header <- function(title, script, machine, loads, other_cores) {
  load_note <- paste0("The one-minute load average before each process, which includes the ",
                      "benchmark's own previous process, was between ", min(loads), " and ",
                      max(loads), ".")
  if (all(is.na(other_cores))) {
    sharing <- "Other work on the machine was not measured (every timed call took under 1 s)."
  } else {
    worst <- max(other_cores, na.rm = TRUE)
    shared <- worst > 0.2
    sharing <- paste0(
      if (shared) "**The machine was shared**: " else "The machine was otherwise idle: ",
      "during the timed calls of 1 s or more other processes kept at most ",
      format(round(worst, 2)), " cores busy (from /proc/stat: the machine's busy time ",
      "less the benchmark process's own)",
      if (shared) ", so absolute times are noisy; ratios within one run count more", ".")
  }
  c(paste("#", title), "",
    paste0("Written by `", script, "` on ", format(Sys.Date()), ". ", machine, "."),
    paste(sharing, load_note))
}

# Numbers to 3 significant digits with thousands separators, for tables.
fmt3 <- function(x) ifelse(is.na(x), "-", formatC(signif(x, 3), format = "fg", digits = 3,
                                                  big.mark = ","))

# A data.frame as a Markdown table.
md_table <- function(df) paste(knitr::kable(df, format = "pipe", row.names = FALSE), collapse = "\n")

# A data set of the SAVE package (the spot-weld and synthetic examples of
# Palomo, Garcia-Donato, Paulo et al.), from its CRAN archive tarball, which
# is downloaded once per R session into tempdir().
load_save <- function(name) {
  dir <- file.path(tempdir(), "SAVE")
  if (!dir.exists(dir)) {
    tarball <- file.path(tempdir(), "SAVE_1.0.tar.gz")
    if (!file.exists(tarball)) {
      utils::download.file("https://cran.r-project.org/src/contrib/Archive/SAVE/SAVE_1.0.tar.gz",
                           tarball, quiet = TRUE)
    }
    utils::untar(tarball, exdir = tempdir())
  }
  e <- new.env()
  load(file.path(dir, "data", paste0(name, ".rda")), e)
  e[[name]]
}


# Loads griddy for a script: the installed package, or the source tree with
# GRIDDY_LOAD_ALL=true (pkgload::load_all(), from the package root); and
# data.table.
load_griddy <- function() {
  suppressPackageStartupMessages({
    if (file.exists("DESCRIPTION") && requireNamespace("pkgload", quietly = TRUE) &&
        identical(Sys.getenv("GRIDDY_LOAD_ALL"), "true")) {
      pkgload::load_all(".", quiet = TRUE)
    } else {
      library(griddy)
    }
    library(data.table)
  })
}

# Writes N random runs of the thesis's test response at n locations to an
# HDF5 library in `dir`, `chunk` runs per append; returns the seconds taken.
write_thesis_hdf5 <- function(dir, N, n, chunk) {
  locations <- seq(0, 1, length.out = n)
  theta <- thesis_theta(n_runs = N)
  time_it(for (k in seq_len(N / chunk)) {
    rows <- (k - 1) * chunk + seq_len(chunk)
    piece <- sim_library(theta[rows, ], thesis_response(as.matrix(theta[rows, ]), locations),
                         t = locations)
    write_library(piece, file.path(dir, "library.h5"), append = k > 1)
  })
}

# A library of N random runs (a and b uniform on [0, 1], drawn after
# set.seed(seed)) of y(x, t) = a (1 + t + x) + b sin(6 t + 2 x) at n_x
# settings x and n_t times t in [0, 1], blocks of t by setting (the
# missing-cell and stream-path benchmarks): list(lib, y, x, t, response).
settings_times_case <- function(N, n_x, n_t, seed) {
  tt <- seq(0, 1, length.out = n_t)
  xs <- data.frame(x = seq(0, 1, length.out = n_x))
  response <- function(a, b) {
    do.call(cbind, lapply(xs$x, function(x) outer(a, 1 + tt + x) + outer(b, sin(6 * tt + 2 * x))))
  }
  set.seed(seed)
  theta <- data.frame(a = runif(N), b = runif(N))
  y <- response(theta$a, theta$b)
  list(lib = griddy::sim_library(theta, y, x = xs, t = tt), y = y, x = xs, t = tt,
       response = response)
}

# A damped oscillation whose amplitude grows with the load; theta = (freq,
# damp) on a per_dim x per_dim grid over [4, 8] x [0.5, 2.5]; 3 loads x n_t
# times; reality (freq 6.03, damp 1.47) adds a slow drift over t that grows
# with the load (the gap), noise sd 0.05. gap-long-field.R's long field and
# discrepancy-ratio.R's libraries.
damped_oscillation_system <- function(per_dim, n_t, seed = 1) {
  set.seed(seed)
  x <- data.frame(load = c(1, 2, 3))
  t <- seq(0, 1, length.out = n_t)
  sim <- function(freq, damp, drift = 0) {
    out <- matrix(0, length(freq), nrow(x) * n_t)
    for (k in seq_len(nrow(x))) {
      l <- x$load[k]
      out[, (k - 1) * n_t + seq_len(n_t)] <- l * exp(-outer(damp, t)) * sin(outer(freq, t)) +
        drift * l * outer(rep(1, length(freq)), t^2)
    }
    out
  }
  theta <- expand.grid(freq = seq(4, 8, length.out = per_dim),
                       damp = seq(0.5, 2.5, length.out = per_dim))
  lib <- griddy::sim_library(theta, sim(theta$freq, theta$damp), x = x, t = t)
  y <- drop(sim(6.03, 1.47, drift = 0.15)) + rnorm(nrow(x) * n_t, sd = 0.05)
  list(lib = lib, field = griddy::field_data(matrix(y, nrow(x), byrow = TRUE), x = x, t = t))
}
