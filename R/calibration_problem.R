# What calibrate() and posterior_exact() share: the validated inputs, the
# correlation setup and the quadratic forms C (runs x correlation grid).

calibration_problem <- function(library, field, rho_x, rho_t, prior, x_power,
                                run_weights) {
  check_library(library)
  y_field <- field_vector(library, field)
  prior <- assert_prior(prior)
  log_prior_run <- log_run_weights(run_weights, lib_n_runs(library))
  setup <- correlation_setup(library, rho_x, rho_t, x_power)
  C <- quad_forms(library, y_field, setup)
  if (prior$rate == 0 && any(C == 0)) {
    griddy_abort("A library run reproduces the field data exactly, so with ",
                 "`prior$rate` = 0 its posterior weight is infinite. Use a positive rate.")
  }
  list(library = library, y_field = y_field, n_obs = length(y_field), prior = prior,
       log_prior_run = log_prior_run, setup = setup, C = C,
       log_prior_rho = rep(-log(ncol(C)), ncol(C)))
}

log_run_weights <- function(run_weights, n_runs) {
  if (is.null(run_weights)) {
    return(rep(-log(n_runs), n_runs))
  }
  w <- assert_numeric_vector(run_weights, "run_weights")
  if (length(w) != n_runs) {
    griddy_abort("`run_weights` must have one weight per library run (", n_runs,
                 "); received ", length(w), ".")
  }
  if (any(w < 0) || sum(w) <= 0) {
    griddy_abort("`run_weights` must be >= 0 with a positive sum.")
  }
  log(w / sum(w))
}

# log p(run i, grid point g | y) up to the normalising constant, with tau
# integrated out: log pi_i + log pi_g - 1/2 log|R_g| - (a + n/2) log(b + C_ig/2).
collapsed_log_joint <- function(problem) {
  shape_post <- problem$prior$shape + problem$n_obs / 2
  lj <- -shape_post * log(problem$prior$rate + problem$C / 2)
  lj <- sweep(lj, 2, problem$log_prior_rho - problem$setup$logdet / 2, "+")
  lj + problem$log_prior_run
}

log_sum_exp <- function(v) {
  top <- max(v)
  top + log(sum(exp(v - top)))
}
