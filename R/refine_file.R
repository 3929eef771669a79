# refine()'s runs on disk (`file =`): every chunk the simulator finishes is
# appended to an HDF5 library by write_library() (its safe appends and lock),
# and the rounds they belong to are listed beside it in `<file>.rounds.csv`
# (a plain table: neither format can run code when read). refine() with the
# same file reads back the runs its fit does not hold yet, so after a failure
# or a killed session no run in the file is simulated again.
#
# The table has one row per round, written before the round's first run:
# its kind ("add": a Latin hypercube in the box lower_*, upper_*; "propose":
# draws from a proposal (four or more parameters, refine_proposal.R), whose
# components are rows of `<file>.proposals.csv`; "replace": predicted runs
# simulated at their theta) and `n`, the runs of it in the
# file, updated after each append. The runs in the file are in round order;
# runs beyond the table's count (a session killed between an append and the
# table's update) belong to its last round.

refine_store <- function(file, library) {
  if (is.null(file)) return(NULL)
  list(file = file, table = paste0(file, ".rounds.csv"),
       proposals = paste0(file, ".proposals.csv"),
       names = names(lib_theta(library)), x = lib_x(library), t = lib_t(library))
}

read_store_table <- function(store) {
  if (!file.exists(store$table)) return(NULL)
  utils::read.csv(store$table, stringsAsFactors = FALSE, check.names = FALSE)
}

# The table written whole under a temporary name, then renamed into place.
write_store_table <- function(store, table) {
  tmp <- paste0(store$table, ".tmp")
  utils::write.csv(table, tmp, row.names = FALSE)
  file.rename(tmp, store$table)
}

# A new round in the table.
store_round <- function(store, kind, box, proposal = NULL) {
  if (is.null(store)) return(invisible())
  p <- length(store$names)
  if (is.null(box)) box <- matrix(NA_real_, 2L, p)
  if (!is.null(proposal)) kind <- "propose"
  row <- data.frame(kind = kind, n = 0L, matrix(c(box[1, ], box[2, ]), 1L,
                                                dimnames = list(NULL, NULL)))
  names(row)[-(1:2)] <- c(paste0("lower_", store$names), paste0("upper_", store$names))
  table <- read_store_table(store)
  if (!is.null(proposal)) write_store_proposal(store, NROW(table) + 1L, proposal)
  write_store_table(store, rbind(table, row))
}

# A round's proposal as plain rows, one per component: its weight, centre
# and Cholesky factor (by column) in unit coordinates, with the proposal's
# df, defensive share and mass inside the range. The range is the base
# library's, which the fit holds.
write_store_proposal <- function(store, round, proposal) {
  rows <- do.call(rbind, lapply(proposal$components, function(cmp) {
    c(round = round, df = proposal$df, defensive = proposal$defensive,
      inside = proposal$inside, beta = proposal$beta, weight = cmp$weight,
      stats::setNames(cmp$centre, paste0("centre_", seq_along(cmp$centre))),
      stats::setNames(as.vector(cmp$chol), paste0("chol_", seq_along(cmp$chol))))
  }))
  old <- if (file.exists(store$proposals)) utils::read.csv(store$proposals) else NULL
  tmp <- paste0(store$proposals, ".tmp")
  utils::write.csv(rbind(old, rows), tmp, row.names = FALSE)
  file.rename(tmp, store$proposals)
}

read_store_proposal <- function(store, round, library) {
  rows <- utils::read.csv(store$proposals)
  rows <- rows[rows$round == round, , drop = FALSE]
  range0 <- library_box(lib_base(library))
  varies <- range0[2, ] > range0[1, ]
  q <- sum(varies)
  components <- lapply(seq_len(nrow(rows)), function(i) {
    list(weight = rows$weight[i], centre = unlist(rows[i, paste0("centre_", seq_len(q))]),
         chol = matrix(unlist(rows[i, paste0("chol_", seq_len(q * q))]), q, q))
  })
  list(range = range0, varies = varies, components = components, df = rows$df[1],
       defensive = rows$defensive[1], inside = rows$inside[1], beta = rows$beta[1])
}

# A function(theta, y) appending finished runs to the file and counting
# them in the table's last round; NULL without a store.
store_keeper <- function(store) {
  if (is.null(store)) return(NULL)
  function(theta, y) {
    commit_runs(runs_piece(theta, y, store$x, store$t), store$file,
                append = file.exists(store$file))
    table <- read_store_table(store)
    table$n[nrow(table)] <- table$n[nrow(table)] + nrow(theta)
    write_store_table(store, table)
  }
}

# The problem with the file's runs that it does not hold yet: an "add"
# round's runs as a round of the refined library, a "replace" round's
# replacing the predicted runs at their theta. Returns list(problem, n =
# the runs taken from the file).
store_resume <- function(store, problem) {
  if (is.null(store) || !file.exists(store$file)) return(list(problem = problem, n = 0L))
  runs <- hdf5_library(store$file)
  table <- read_store_table(store)
  if (!identical(names(lib_theta(runs)), store$names) || is.null(table)) {
    griddy_abort("`file` (", store$file, ") does not hold refine()'s runs of this fit's ",
                 "library", if (is.null(table)) paste0(" (its table of rounds, ", store$table,
                                                       ", is missing)") else
                   paste0(": its parameters are ", show_some(names(lib_theta(runs)))),
                 "; give another `file`.", class = "library")
  }
  n_file <- lib_n_runs(runs)
  counts <- table$n
  counts[length(counts)] <- counts[length(counts)] + max(0L, n_file - sum(counts))
  ends <- pmin(cumsum(counts), n_file)
  taken <- 0L
  for (r in seq_len(nrow(table))) {
    rows <- seq_len(ends[r] - c(0L, ends)[r]) + c(0L, ends)[r]
    if (length(rows) == 0L) next
    theta <- lib_theta(runs)[rows, , drop = FALSE]
    y <- lib_outputs(runs, rows)
    held <- match(run_keys(theta), run_keys(lib_theta(problem$library)))
    if (table$kind[r] == "replace") {
      todo <- which(!is.na(held))
      todo <- todo[lib_predicted(problem$library)[held[todo]]]
      if (length(todo) == 0L) next
      problem <- replace_in_problem(problem, held[todo], y[todo, , drop = FALSE])
    } else {
      todo <- which(is.na(held))
      if (length(todo) == 0L) next
      round <- if (table$kind[r] == "propose") {
        list(box = NULL, proposal = read_store_proposal(store, r, problem$library))
      } else {
        list(box = unname(rbind(unlist(table[r, paste0("lower_", store$names)]),
                                unlist(table[r, paste0("upper_", store$names)]))))
      }
      round <- c(round, list(n = length(todo), source = "simulator", error = NULL))
      problem <- extend_problem(problem, theta[todo, , drop = FALSE], y[todo, , drop = FALSE],
                                round, NULL)
    }
    taken <- taken + length(todo)
  }
  list(problem = problem, n = taken)
}

# Exact keys of theta rows (hexadecimal doubles), to find runs again.
run_keys <- function(theta) {
  do.call(paste, c(lapply(theta, function(v) sprintf("%a", v)), sep = "|"))
}
