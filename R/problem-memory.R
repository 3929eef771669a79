# What a calibration holds in memory, said up front: the misfit table C
# (runs x grid points, double precision: 8 bytes an entry), the thesis
# update's run order (an integer an entry) and the library's outputs, in
# memory or on disk. print() of a fit states it (fit_description()), and a
# precompute whose C needs a gigabyte or more announces it first.

# "misfit table C: 59,319 runs x 1,000 grid points, 474.6 MB; library
# outputs: 25.6 MB in memory"; `update = "thesis"` adds the run order.
memory_statement <- function(library, n_grid, update = NULL) {
  n_runs <- lib_n_runs(library)
  paste0("misfit table C: ", format_count(n_runs), " runs x ", format_count(n_grid),
         " grid point", if (n_grid != 1) "s", ", ", format_bytes(8 * n_runs * n_grid),
         if (identical(update, "thesis")) {
           paste0(" (and its run order for the thesis update, ",
                  format_bytes(4 * n_runs * n_grid), ")")
         },
         "; library outputs: ", format_bytes(8 * n_runs * lib_n_out(library)),
         if (lib_on_disk(library)) " on disk" else " in memory")
}

# The size of C from which calibrate() and posterior_exact() announce it
# (class griddy_message_memory) before computing it.
memory_message_bytes <- 1e9

inform_memory <- function(library, n_grid, update = NULL, threshold = memory_message_bytes) {
  if (8 * lib_n_runs(library) * n_grid < threshold) return(invisible(NULL))
  rlang::inform(paste0("Computing the ", memory_statement(library, n_grid, update), "."),
                class = c("griddy_message_memory", "griddy_message"))
}

format_count <- function(n) format(n, big.mark = ",", scientific = FALSE, trim = TRUE)

# Bytes in SI units: "474.6 MB".
format_bytes <- function(bytes) {
  format(structure(bytes, class = "object_size"), units = "auto", standard = "SI")
}
