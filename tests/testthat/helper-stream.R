# A stream's posterior beside posterior_exact() on the same data (stream_data()).
stream_vs_batch <- function(s, lib, ...) {
  field <- field_data(stream_data(s))
  batch <- suppressWarnings(posterior_exact(lib, field, ...))
  list(stream = posterior_exact(s), batch = batch)
}
