# One writer at a time. A writer takes the lock `<path>.lock` by creating it
# with dir.create(), which is atomic on POSIX file systems (and on NFS v3+):
# of two processes creating it, exactly one succeeds. The winner records its
# pid, host and start time in `<path>.lock/owner`; a refused writer reports
# them. A writer that dies leaves the lock behind: griddy never breaks a lock
# on its own (it cannot tell a dead writer on another host from a slow one);
# the message says how to remove it once no writer is at work.

lock_path <- function(path) paste0(path, ".lock")

# Takes the lock or stops with a `griddy_error_lock` naming its owner.
library_lock <- function(path, what = "library") {
  lock <- lock_path(path)
  parent <- dirname(lock)
  if (!dir.exists(parent)) {
    griddy_abort("Cannot write the ", what, " `", path, "`: its directory ", parent,
                 " does not exist.")
  }
  if (!dir.create(lock, showWarnings = FALSE)) {
    if (dir.exists(lock)) {
      griddy_abort(lock_refusal(path, lock), class = "lock")
    }
    griddy_abort("Cannot create the lock ", lock, " for writing `", path,
                 "` (is the directory writable?).", class = "lock")
  }
  token <- list(lock = lock, pid = Sys.getpid(), host = lock_host(),
                time = format(Sys.time(), "%Y-%m-%d %H:%M:%S %Z"))
  writeLines(c(paste0("pid: ", token$pid), paste0("host: ", token$host),
               paste0("since: ", token$time)), file.path(lock, "owner"))
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

# The owner recorded in a lock: a list of pid, host and since (NA if unknown).
lock_owner <- function(lock) {
  owner <- list(pid = NA_character_, host = NA_character_, since = NA_character_)
  lines <- tryCatch(readLines(file.path(lock, "owner"), warn = FALSE),
                    error = function(e) character(0), warning = function(w) character(0))
  for (key in names(owner)) {
    hit <- grep(paste0("^", key, ": "), lines, value = TRUE)
    if (length(hit) == 1L) owner[[key]] <- sub(paste0("^", key, ": "), "", hit)
  }
  owner
}

# Whether the owner of a lock is known to be dead: on this host, with no
# process of that pid. (A pid may be reused; a live pid is taken as alive.)
lock_is_stale <- function(owner) {
  !is.na(owner$pid) && identical(owner$host, lock_host()) &&
    !isTRUE(tools::pskill(as.integer(owner$pid), 0L))
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
           "that died. If no other writer is at work on `", path, "`, remove the lock with ",
           "unlink(\"", lock, "\", recursive = TRUE) and run ", repair,
           " to discard any runs the dead writer left uncommitted.")
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
