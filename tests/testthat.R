library(testthat)
library(griddy)

test_check("griddy")
