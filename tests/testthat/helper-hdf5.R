# Rows past the committed count of a write_library() file, as a writer that
# died part-way leaves them (written with hdf5r, the count untouched).
leave_uncommitted <- function(file, library) {
  h5 <- hdf5r::H5File$new(file, "r+")
  on.exit(h5$close_all())
  theta <- h5[["theta"]]
  y <- h5[["y"]]
  n0 <- theta$dims[1]
  k <- nrow(library$y)
  theta$set_extent(c(n0 + k, ncol(library$theta)))
  y$set_extent(c(n0 + k, ncol(library$y)))
  theta$write(args = list(n0 + seq_len(k), seq_len(ncol(library$theta))),
              as.matrix(library$theta))
  y$write(args = list(n0 + seq_len(k), seq_len(ncol(library$y))), library$y)
  invisible(file)
}

# Runs R code in a child Rscript under a file-size limit of `kb` kB (the
# shell's ulimit -f, SIGXFSZ ignored so that a write past it fails with
# EFBIG as on a full disk); returns the exit status.
run_child_limited <- function(code, kb) {
  script <- child_script(code)
  cmd <- sprintf("trap '' XFSZ; ulimit -f %d; exec %s %s", as.integer(kb),
                 shQuote(file.path(R.home("bin"), "Rscript")), shQuote(script))
  system2("bash", c("-c", shQuote(cmd)), stdout = FALSE, stderr = FALSE)
}
