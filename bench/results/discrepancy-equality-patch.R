ns <- asNamespace("griddy")
e <- new.env(parent = ns); source("bench/results/discrepancy-equality-sqrt.R", local = e)
assignInNamespace("discrepancy_draws", e$discrepancy_draws, "griddy")
