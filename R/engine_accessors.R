# Accessors of the engine's setup (grid_posterior.R) for the files outside
# it, so that none of them reads the engine's dense factors directly. (Kept
# apart from grid_posterior.R only while another change owns that file: they
# belong beside grid_point().)

# The data a setup's noise model sees, the same at every grid point: the
# observed library outputs `obs` (library order), their 1/sd `scale` (NULL
# without relative sd or replicates) and the noise groups `groups`
# (positions in `obs`, one element per group). NULL for a setup in the
# Kronecker case (complete data, one group, no sd), where every output is
# observed.
noise_layout <- function(setup) {
  if (is.null(setup$dense)) return(NULL)
  setup$dense[c("obs", "scale", "groups")]
}

# The observed library outputs of a setup (library order): every one of the
# `n` outputs in the Kronecker case.
observed_outputs <- function(setup, n) {
  layout <- noise_layout(setup)
  if (is.null(layout)) seq_len(n) else layout$obs
}
