# A campaign's simulator: y = sin(k t) + c at 20 times, one row per theta
# row, recording every k it is given (in `seen`); rows whose k is in
# `broken` make the whole call fail.
campaign_sim <- function(broken = numeric(0)) {
  env <- new.env()
  env$seen <- numeric(0)
  env$broken <- broken
  env$sim <- function(theta) {
    if (any(theta$k %in% env$broken)) stop("the mesh did not converge at k = ",
                                           theta$k[theta$k %in% env$broken][1])
    env$seen <- c(env$seen, theta$k)
    campaign_outputs(theta)
  }
  env
}

campaign_t <- seq(0, 1, length.out = 20)

campaign_outputs <- function(theta) {
  t(mapply(function(k, c) sin(k * campaign_t) + c, theta$k, theta$c))
}

# Every design row in the library exactly once, with the simulator's outputs.
expect_complete_campaign <- function(lib, design) {
  theta <- as.data.frame(lib)
  expect_equal(nrow(theta), nrow(design))
  expect_setequal(paste(theta$k, theta$c), paste(design$k, design$c))
  expect_equal(as.matrix(lib), campaign_outputs(theta), ignore_attr = TRUE)
}
