# What an interrupt leaves behind under a multisession future plan: a
# calibrate() call with two long chains on two workers is interrupted after
# 3 s (SIGINT from a child shell, as Ctrl-C would send), then a short call
# is timed: it waits until the workers are free. Before griddy 0.1.1 the
# workers ran their chains to the end; now an interrupt writes a stop file
# and each worker stops after its current piece (at most 1000 iterations).
# Usage, from the package root after installing griddy:
#   Rscript bench/interrupt.R
# and, for the old behaviour, with an older griddy installed in LIB:
#   R_LIBS=LIB Rscript bench/interrupt.R
library(griddy)
future::plan("multisession", workers = 2)
t <- seq(0, 1, length.out = 50)
theta <- data.frame(a = seq(0, 1, length.out = 20000))
lib <- sim_library(theta, t(vapply(theta$a, function(a) sin(6 * t + a), numeric(50))), t = t)
set.seed(1)
field <- field_data(sin(6 * t + 0.3) + rnorm(50, sd = 0.1))
invisible(calibrate(lib, field, n_iter = 200, burn_in = 10, chains = 2, seed = 1)) # warm up
system(sprintf("(sleep 3; kill -INT %d) >/dev/null 2>&1 &", Sys.getpid()))
t0 <- Sys.time()
first <- tryCatch(calibrate(lib, field, rho_t = c(0, 0.3, 0.6, 0.9), update = "thesis",
                            n_iter = 3e6, burn_in = 10, thin = 1000, chains = 2, seed = 2),
                  interrupt = function(e) "interrupted")
interrupted_after <- as.numeric(Sys.time() - t0, units = "secs")
t1 <- Sys.time()
invisible(calibrate(lib, field, n_iter = 200, burn_in = 10, chains = 2, seed = 3))
next_call <- as.numeric(Sys.time() - t1, units = "secs")
cat(sprintf("griddy %s: first call %s after %.1f s; the next call took %.1f s\n",
            utils::packageVersion("griddy"), if (is.character(first)) first else "finished",
            interrupted_after, next_call))
