# Reads a file of the lanl/SEPIA repository (BSD-3) from a checkout or a bare
# git snapshot (what `fetch` brings): one reader for every script that uses
# SEPIA's published data. SEPIA_DIR: where the repository is.
sepia_dir <- Sys.getenv("SEPIA_DIR", "/work/.mirror/lanl+SEPIA/repo")
sepia_file <- function(path) {
  if (file.exists(file.path(sepia_dir, path))) return(readLines(file.path(sepia_dir, path)))
  system2("git", c("--git-dir", shQuote(sepia_dir), "show", paste0("HEAD:", path)),
          stdout = TRUE)
}
