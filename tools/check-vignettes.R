# Check the rendered vignettes as a reader sees them, in headless Chromium.
#
# Usage, from the package root:
#
#   R CMD INSTALL . && Rscript tools/check-vignettes.R   # the installed vignettes
#   Rscript tools/check-vignettes.R DIR_OR_HTML ...      # other renderings
#   Rscript tools/check-vignettes.R --shots DIR ...      # and a full-page PNG of each
#
# R CMD build renders the vignettes with knitr's engine, which without
# rmarkdown (not a dependency) hands the Markdown to litedown, not to Pandoc
# as the site does: captions, superscripts and tables that read well on the
# site can be lost in the installed HTML. tools/check-site.R checks the site;
# this checks the HTML of `vignette()` and `browseVignettes()`, with the
# checks of tools/reader-checks.js (tables wider than the text, raw x^y^
# superscripts, figures whose caption is only alt text, "Table:" captions
# left as text, mailto: links that are no address). It needs Chromium
# (Debian's `chromium`, or set CHROMIUM) and jsonlite, and no network: the
# pages' remote stylesheets may fail to load, which moves nothing checked
# here by much (the text column is litedown's own, 800 px). It exits
# non-zero on any failure. CI does not run this.

args <- commandArgs(trailingOnly = TRUE)
shots <- NULL
at <- match("--shots", args)
if (!is.na(at)) {
  shots <- args[[at + 1L]]
  args <- args[-c(at, at + 1L)]
  dir.create(shots, recursive = TRUE, showWarnings = FALSE)
}
if (!requireNamespace("jsonlite", quietly = TRUE)) stop("tools/check-vignettes.R needs jsonlite")
chromium <- Sys.getenv("CHROMIUM", Sys.which("chromium"))
if (!nzchar(chromium)) stop("no Chromium found: install Debian's chromium or set CHROMIUM")
script_dir <- local({
  file <- sub("^--file=", "", grep("^--file=", commandArgs(FALSE), value = TRUE))
  if (length(file)) dirname(normalizePath(file[1])) else "tools"
})
checks_js <- paste(readLines(file.path(script_dir, "reader-checks.js"), encoding = "UTF-8"),
                   collapse = "\n")

if (length(args) == 0L) {
  args <- system.file("doc", package = "griddy")
  if (!nzchar(args)) stop("griddy is not installed with its vignettes: run `R CMD INSTALL .`")
}
pages <- unlist(lapply(args, function(p) {
  if (dir.exists(p)) list.files(p, "\\.html$", full.names = TRUE) else p
}))
pages <- normalizePath(pages[!grepl("\\.reader-checks\\.html$", pages)])
if (length(pages) == 0L) stop("no HTML files in ", paste(args, collapse = ", "))

# A copy of the page that, once loaded, writes the checks' answer (and the
# page's height, for its screenshot) into a <pre> that --dump-dom prints.
# The copy goes to a temporary directory: the installed doc/ may not be
# writable, and the vignettes are self-contained (figures as data: URIs).
probe_page <- function(page) {
  probe <- paste0(
    "<script>window.addEventListener('load', () => {\nconst r = ", checks_js, ";\n",
    "r.height = document.documentElement.scrollHeight;\n",
    "const p = document.createElement('pre'); p.id = 'griddy-reader-checks';\n",
    "p.textContent = JSON.stringify(r); document.body.appendChild(p);\n});</script>")
  html <- paste(readLines(page, encoding = "UTF-8", warn = FALSE), collapse = "\n")
  at <- regexpr("</body>", html, fixed = TRUE)
  html <- if (at > 0) paste0(substr(html, 1, at - 1), probe, substring(html, at)) else
    paste0(html, probe)
  copy <- file.path(tempdir(), sub("\\.html$", ".reader-checks.html", basename(page)))
  writeLines(html, copy, useBytes = TRUE)
  copy
}

chromium_run <- function(...) {
  system2(chromium, c("--headless", "--disable-gpu", "--no-sandbox", "--hide-scrollbars",
                      "--window-size=1000,1000", ...), stdout = TRUE, stderr = FALSE)
}

check_page <- function(page) {
  copy <- probe_page(page)
  dom <- chromium_run("--virtual-time-budget=15000", "--dump-dom", paste0("file://", copy))
  dom <- paste(dom, collapse = "\n")
  m <- regmatches(dom, regexec("<pre id=\"griddy-reader-checks\">(.*?)</pre>", dom))[[1]]
  if (length(m) < 2L) return(list(failures = "the page did not load (no checks ran)", height = NA))
  json <- m[2]
  for (e in list(c("&lt;", "<"), c("&gt;", ">"), c("&quot;", "\""), c("&amp;", "&"))) {
    json <- gsub(e[1], e[2], json, fixed = TRUE)
  }
  r <- jsonlite::fromJSON(json, simplifyVector = TRUE)
  what <- c(wide_tables = "table wider than the text", raw_superscripts = "raw superscript",
            alt_only_captions = "figure caption only in alt text",
            stray_captions = "table caption left as text", odd_mailto = "mailto: link in text")
  failures <- unlist(lapply(names(what), function(k) {
    if (length(r[[k]])) paste0(what[[k]], ": ", r[[k]]) else character()
  }))
  if (!is.null(shots)) {
    png <- file.path(normalizePath(shots), sub("\\.html$", ".png", basename(page)))
    height <- min(r$height, 16000)  # Chromium's screenshots stop near 16,384 px
    chromium_run(sprintf("--window-size=1000,%d", height), paste0("--screenshot=", png),
                 paste0("file://", page))
  }
  unlink(copy)
  list(failures = failures, height = r$height)
}

failed <- 0L
for (page in pages) {
  res <- check_page(page)
  cat(sprintf("%-28s %s\n", basename(page),
              if (length(res$failures)) sprintf("%d problem(s)", length(res$failures)) else "ok"))
  if (length(res$failures)) {
    cat(paste0("    - ", res$failures), sep = "\n")
    failed <- failed + 1L
  }
}
if (!is.null(shots)) cat("screenshots in", normalizePath(shots), "\n")
if (failed) {
  cat(sprintf("\nFAILED: %d of %d page(s)\n", failed, length(pages)))
  quit(status = 1)
}
cat(sprintf("\nAll %d page(s) pass.\n", length(pages)))
