# One writer at a time. A writer takes the lock `<path>.lock` by creating it
# with dir.create(), which is atomic on POSIX file systems (and on NFS v3+):
# of two processes creating it, exactly one succeeds. The winner records its
# pid, host, start time, the machine's boot id and the process's start tick
# in `<path>.lock/owner`; a refused writer reports them.
#
# A writer that dies leaves the lock behind. As SQLite recovers a hot
# journal, the next writer on the same host that finds the lock's owner dead
# (no process of that pid, another boot, or a pid reused by a process started
# later) takes the lock over and repairs the file before anything else (see
# lock_take_stale()). A lock held from another host is never broken: griddy
# cannot tell a dead writer there from a slow one, and the message says how
# to remove it.

lock_path <- function(path) paste0(path, ".lock")

# Takes the lock or stops with a `griddy_error_lock` naming its owner. A lock
# whose owner is dead (see lock_is_stale()) is taken over when `recover` is a
# function: it runs under the lock, before the caller does anything, to
# repair what the dead writer left; griddy says so with a message of class
# `griddy_message_lock_recovered`.
library_lock <- function(path, what = "library", recover = NULL) {
  lock <- lock_path(path)
  parent <- dirname(lock)
  if (!dir.exists(parent)) {
    griddy_abort("Cannot write the ", what, " `", path, "`: its directory ", parent,
                 " does not exist.")
  }
  if (dir.create(lock, showWarnings = FALSE)) return(lock_write_owner(lock))
  if (!dir.exists(lock)) {
    griddy_abort("Cannot create the lock ", lock, " for writing `", path,
                 "` (is the directory writable?).", class = "lock")
  }
  dead <- lock_owner(lock)
  if (!is.function(recover) || !lock_is_stale(dead) || !lock_take_stale(lock)) {
    griddy_abort(lock_refusal(path, lock), class = "lock")
  }
  token <- list(lock = lock, pid = Sys.getpid(), host = lock_host())
  done <- withCallingHandlers(recover(), error = function(e) library_unlock(token))
  cli::cli_inform(c("!" = paste0("{.path {path}}: took over the lock of a writer that died ",
                                 "({lock_who(dead)}); {done}")),
                  class = c("griddy_message_lock_recovered", "griddy_message"))
  token
}

# Replaces a dead owner's lock by ours. Two writers may find the same dead
# lock: the right to take it over is itself a lock (a directory created
# inside it), and the owner is read again under it, so that a writer that
# comes late finds the first one's live lock and is refused.
lock_take_stale <- function(lock) {
  breaker <- file.path(lock, "recovering")
  if (!dir.create(breaker, showWarnings = FALSE)) return(FALSE)
  on.exit(unlink(breaker, recursive = TRUE), add = TRUE)
  if (!lock_is_stale(lock_owner(lock))) return(FALSE)
  lock_write_owner(lock)
  TRUE
}

# Records this process as the lock's owner (written aside and renamed, so a
# reader sees the old owner or the new one, never half of one).
lock_write_owner <- function(lock) {
  token <- list(lock = lock, pid = Sys.getpid(), host = lock_host(),
                time = format(Sys.time(), "%Y-%m-%d %H:%M:%S %Z"))
  tmp <- file.path(lock, paste0("owner.", token$pid))
  writeLines(c(paste0("pid: ", token$pid), paste0("host: ", token$host),
               paste0("since: ", token$time), paste0("boot: ", lock_boot_id()),
               paste0("start: ", lock_proc_start(token$pid))), tmp)
  file.rename(tmp, file.path(lock, "owner"))
  token
}

# Removes the lock if it is still ours.
library_unlock <- function(token) {
  owner <- lock_owner(token$lock)
  if (identical(owner$pid, as.character(token$pid)) && identical(owner$host, token$host)) {
    unlink(token$lock, recursive = TRUE)
  }
  invisible(NULL)
}

lock_host <- function() Sys.info()[["nodename"]]

# The owner recorded in a lock: a list of pid, host, since, boot and start
# (NA if unknown; locks written by earlier versions have no boot or start).
lock_owner <- function(lock) {
  owner <- list(pid = NA_character_, host = NA_character_, since = NA_character_,
                boot = NA_character_, start = NA_character_)
  lines <- tryCatch(readLines(file.path(lock, "owner"), warn = FALSE),
                    error = function(e) character(0), warning = function(w) character(0))
  for (key in names(owner)) {
    hit <- grep(paste0("^", key, ": "), lines, value = TRUE)
    if (length(hit) == 1L && nzchar(v <- sub(paste0("^", key, ": "), "", hit)) && v != "NA") {
      owner[[key]] <- v
    }
  }
  owner
}

# Whether the owner of a lock is known to be dead: on this host, and no
# process of that pid, or the machine booted since (another boot id), or the
# pid now belongs to a process started at another tick (the pid was reused).
# Without the boot id and start tick (not Linux) a live pid is taken as alive.
lock_is_stale <- function(owner) {
  if (is.na(owner$pid) || !identical(owner$host, lock_host())) return(FALSE)
  if (!is.na(owner$boot) && !identical(owner$boot, lock_boot_id())) return(TRUE)
  if (!isTRUE(tools::pskill(as.integer(owner$pid), 0L))) return(TRUE)
  # a killed process not yet reaped by its parent (a zombie) answers signals
  if (lock_proc_field(owner$pid, 1L) %in% c("Z", "X")) return(TRUE)
  !is.na(owner$start) && !identical(owner$start, lock_proc_start(owner$pid))
}

# Linux's boot id and a process's start time in clock ticks since boot
# (field 22 of /proc/<pid>/stat, after the command name, which may hold
# spaces); NA elsewhere.
lock_boot_id <- function() {
  lock_read_line("/proc/sys/kernel/random/boot_id")
}

lock_proc_start <- function(pid) lock_proc_field(pid, 20L)

# Field `k` of /proc/<pid>/stat counted after the command name (1 is the
# state, 20 the start time); NA when unknown.
lock_proc_field <- function(pid, k) {
  stat <- lock_read_line(file.path("/proc", pid, "stat"))
  if (is.na(stat)) return(NA_character_)
  fields <- strsplit(sub("^.*\\) ", "", stat), " ", fixed = TRUE)[[1]]
  if (length(fields) < k) NA_character_ else fields[k]
}

lock_read_line <- function(file) {
  out <- tryCatch(readLines(file, n = 1L, warn = FALSE), error = function(e) character(0),
                  warning = function(w) character(0))
  if (length(out) == 1L && nzchar(out)) out else NA_character_
}

lock_who <- function(owner) {
  if (is.na(owner$pid)) {
    "a writer that has not recorded itself (it has just started, or died at once)"
  } else {
    paste0("process ", owner$pid, " on host ", owner$host, " since ", owner$since)
  }
}

lock_refusal <- function(path, lock) {
  # an old .rds directory is read only when trusted (see ?disk_library)
  repair <- paste0("repair_library(\"", path, "\"", if (dir.exists(path)) ", trust = TRUE", ")")
  owner <- lock_owner(lock)
  who <- lock_who(owner)
  advice <- if (lock_is_stale(owner)) {
    paste0(" That process is no longer running: the lock is stale, left by a writer ",
           "that died. ", repair, " takes it over and discards any runs the dead writer ",
           "left uncommitted (as the next write_library() or simulate_library() on it does).")
  } else {
    paste0(" Wait for that writer to finish. If it is known to have died (on another host ",
           "griddy cannot tell), remove the lock with unlink(\"", lock,
           "\", recursive = TRUE) and run ", repair, ".")
  }
  paste0("`", path, "` is being written by another writer: the lock ", lock, " is held by ",
         who, ".", advice)
}

# Test hook: lets tests stop or kill a writer between the steps of a write.
write_hook <- function(step) {
  hook <- getOption("griddy.write_hook")
  if (is.function(hook)) hook(step)
  invisible(NULL)
}
