# refine()'s runs on disk (`file =`): every chunk the simulator finishes is
# appended to an HDF5 library by write_library() (its safe appends and lock),
# and the rounds they belong to are listed beside it in `<file>.rounds.csv`
# (a plain table: neither format can run code when read). refine() with the
# same file reads back the runs its fit does not hold yet, so after a failure
# or a killed session no run in the file is simulated again.
#
# The table has one row per round, written before the round's first run:
# its kind ("add": a Latin hypercube in the box lower_*, upper_*; "propose":
# draws from a proposal (four or more parameters, refine-proposal.R), whose
# components are rows of `<file>.proposals.csv`; "replace": predicted runs
# simulated at their theta) and `n`, the runs of it in the
# file, updated after each append. The runs in the file are in round order;
# runs beyond the table's count (a session killed between an append and the
# table's update) belong to its last round.
#
# Each side file ends with a line `# md5 <checksum>`, the MD5 sum of the
# lines before it, written with them and renamed into place in one step: a
# side file with a row missing, a value changed or no checksum line is named
# as damaged (class griddy_error_damaged) and never resumed, and a missing one
# is named too. The file's runs must have the fit's parameters, x settings
# and outputs (class griddy_error_library).

refine_store <- function(file, library) {
  if (is.null(file)) return(NULL)
  list(file = file, table = paste0(file, ".rounds.csv"),
       proposals = paste0(file, ".proposals.csv"),
       names = names(lib_theta(library)), x = lib_x(library), t = lib_t(library))
}

read_store_table <- function(store) {
  if (!file.exists(store$table)) return(NULL)
  read_checked_csv(store$table, store, "table of rounds")
}

write_store_table <- function(store, table) write_checked_csv(table, store$table)

# A table written whole with its checksum line under a temporary name, then
# renamed into place: a kill leaves the old file or the new one.
write_checked_csv <- function(table, path) {
  tmp <- paste0(path, ".tmp")
  utils::write.csv(table, tmp, row.names = FALSE)
  cat("# md5 ", unname(tools::md5sum(tmp)), "\n", file = tmp, append = TRUE, sep = "")
  file.rename(tmp, path)
}

# A side file read back after its checksum is checked; a damaged or missing
# one stops with what to do.
read_checked_csv <- function(path, store, what) {
  if (!file.exists(path)) {
    griddy_abort("refine()'s ", what, " beside `file` (", path, ") is missing, so the runs ",
                 "in ", store$file, " cannot be placed in their rounds. Restore it, or give ",
                 "another `file` (the runs in ", store$file, " stay readable with ",
                 "hdf5_library()).", class = "damaged")
  }
  bytes <- readBin(path, "raw", file.size(path))
  text <- rawToChar(bytes)
  at <- regexpr("(^|\n)# md5 [0-9a-f]{32}\n$", text)
  body <- if (at > 0L) substr(text, 1L, at + (substr(text, at, at) == "\n") - 1L) else ""
  stored <- if (at > 0L) sub("(?s).*# md5 ([0-9a-f]{32})\n$", "\\1", text, perl = TRUE) else ""
  if (at < 0L || !identical(unname(text_md5(body)), stored)) {
    griddy_abort("refine()'s ", what, " beside `file` (", path, ") is damaged: ",
                 if (at < 0L) "its checksum line is missing" else
                   "its checksum does not match its contents",
                 " (a row lost or changed), so the runs in ", store$file, " cannot be placed ",
                 "in their rounds safely. Restore it, or give another `file` (the runs in ",
                 store$file, " stay readable with hdf5_library()).", class = "damaged")
  }
  utils::read.csv(text = body, stringsAsFactors = FALSE, check.names = FALSE)
}

text_md5 <- function(text) {
  tmp <- tempfile()
  on.exit(unlink(tmp))
  writeBin(charToRaw(text), tmp)
  tools::md5sum(tmp)
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
# df, defensive share and mass inside the range; `local` flags the local
# components (refine-ridge.R), `local_share` their share, `search` a search
# round's (refine-modes.R: its seeds draw from boxes, so its density is
# not a t mixture's). The range is the base library's, which the fit holds.
write_store_proposal <- function(store, round, proposal) {
  local <- rep(c(0, 1), c(length(proposal$components), length(proposal[["local"]])))
  share <- if (is.null(proposal$local_share)) 0 else proposal$local_share
  rows <- do.call(rbind, Map(function(cmp, is_local) {
    c(round = round, df = proposal$df, defensive = proposal$defensive,
      inside = proposal$inside, beta = proposal$beta, local_share = share,
      search = as.numeric(is_search_proposal(proposal)), local = is_local, weight = cmp$weight,
      stats::setNames(cmp$centre, paste0("centre_", seq_along(cmp$centre))),
      stats::setNames(as.vector(cmp$chol), paste0("chol_", seq_along(cmp$chol))))
  }, c(proposal$components, proposal[["local"]]), local))
  old <- if (file.exists(store$proposals)) {
    read_checked_csv(store$proposals, store, "table of proposals")
  }
  # rows of this round left by a session killed before its table row was
  # written are replaced
  old <- old[old$round < round, , drop = FALSE]
  if (!is.null(old) && is.null(old[["local"]])) {
    old <- cbind(old[, 1:5], local_share = rep(0, nrow(old)), local = rep(0, nrow(old)),
                 old[, -(1:5)])
  }
  if (!is.null(old) && is.null(old[["search"]])) {
    old <- cbind(old[, 1:6], search = rep(0, nrow(old)), old[, -(1:6)])
  }
  write_checked_csv(rbind(old, rows), store$proposals)
}

read_store_proposal <- function(store, round, library) {
  rows <- read_checked_csv(store$proposals, store, "table of proposals")
  rows <- rows[rows$round == round, , drop = FALSE]
  if (nrow(rows) == 0L) {
    griddy_abort("refine()'s table of proposals beside `file` (", store$proposals, ") has no ",
                 "proposal for round ", round, ": it is damaged. Give another `file`.",
                 class = "damaged")
  }
  range0 <- library_box(lib_base(library))
  varies <- range0[2, ] > range0[1, ]
  q <- sum(varies)
  components <- lapply(seq_len(nrow(rows)), function(i) {
    list(weight = rows$weight[i], centre = unlist(rows[i, paste0("centre_", seq_len(q))]),
         chol = matrix(unlist(rows[i, paste0("chol_", seq_len(q * q))]), q, q))
  })
  # the local components of refine-ridge.R (none in a file written before them)
  local <- if (is.null(rows[["local"]])) rep(FALSE, nrow(rows)) else rows$local == 1
  proposal <- list(range = range0, varies = varies, components = components[!local],
                   df = rows$df[1], defensive = rows$defensive[1], inside = rows$inside[1],
                   beta = rows$beta[1], local = if (any(local)) components[local],
                   local_share = if (is.null(rows$local_share)) 0 else rows$local_share[1])
  # a search round's (none in a file written before them)
  if (!is.null(rows[["search"]]) && rows$search[1] == 1) proposal$search <- TRUE
  proposal
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
  check_store_layout(store, runs)
  table <- read_checked_csv(store$table, store, "table of rounds")
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
    held <- match_rows(theta, lib_theta(problem$library))
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

# The runs in the file must be this fit's kind of runs: its parameters, x
# settings and output coordinates (to match_rows()'s tolerance).
check_store_layout <- function(store, runs) {
  same <- function(a, b) {
    if (is.null(a) || is.null(b)) return(is.null(a) && is.null(b))
    a <- as.data.frame(a)
    b <- as.data.frame(b)
    identical(dim(a), dim(b)) && identical(match_rows(a, b), seq_len(nrow(a)))
  }
  show <- function(v) show_some(format(unlist(v), digits = 6))
  diff <- if (!identical(names(lib_theta(runs)), store$names)) {
    paste0("its parameters are ", show_some(names(lib_theta(runs))), ", the fit's ",
           show_some(store$names))
  } else if (!same(lib_x(runs), store$x) || !identical(names(lib_x(runs)), names(store$x))) {
    paste0("its x settings are ", if (is.null(lib_x(runs))) "none" else show(lib_x(runs)),
           ", the fit's ", if (is.null(store$x)) "none" else show(store$x))
  } else if (!same(list(lib_t(runs)), list(store$t))) {
    paste0("its outputs are at t = ", show(lib_t(runs)), " (", length(lib_t(runs)),
           " per x setting), the fit's at t = ", show(store$t), " (", length(store$t), ")")
  }
  if (!is.null(diff)) {
    griddy_abort("`file` (", store$file, ") does not hold runs of this fit's library: ", diff,
                 ". Give another `file`.", class = "library")
  }
  invisible()
}
