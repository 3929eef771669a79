# Build griddy's pkgdown site and check every page in headless Chromium.
#
# Usage, from the package root (install this tree first: the articles knit
# against the INSTALLED griddy, and the reference examples run with it):
#
#   R CMD INSTALL . && Rscript tools/check-site.R
#   Rscript tools/check-site.R --dest DIR --shots DIR   # other directories
#   Rscript tools/check-site.R --no-build               # check an existing build
#   Rscript tools/check-site.R --lazy                   # rebuild only what changed
#
# Needs pkgdown >= 2.1.2 (the first that caches its CDN files, which the
# offline build below relies on, and whose KaTeX includes the auto-render
# part that renders the help pages' maths; tested with 2.2.1), chromote
# (CRAN), the evaluate version pkgdown suggests (it runs the examples with
# it), and a Chrome or Chromium (Debian's `chromium`; chromote finds it, or
# set CHROMOTE_CHROME). It stops at once on an older pkgdown or evaluate.
# CI does not run this.
#
# It builds the site with pkgdown::build_site() into --dest (default docs/,
# which is git- and build-ignored): the build itself fails when a help topic
# is missing from the reference index of _pkgdown.yml, an example errors or an
# article does not knit. Then it opens EVERY page in headless Chromium
# (chromote) and checks, in the rendered page:
#   - it renders: a non-empty body and <main>, no JavaScript exception, and no
#     R error ("Error in ...", "Error: ...") in any output block (<pre>);
#   - every figure loads: each <img> has naturalWidth > 0;
#   - its maths is rendered: no \( or \[ left in the text outside code;
#   - what a reader sees (tools/reader-checks.js, also run on the installed
#     vignettes by tools/check-vignettes.R): no table wider than the text
#     column, no raw x^y^ superscript, no figure whose caption is only its
#     alt text, no "Table: ..." caption left as text, no mailto: link whose
#     text is no address;
#   - no link is broken: every internal <a href>, stylesheet and script
#     resolves to a file of the site, and every #fragment to an element with
#     that id on the target page. External (http/https/mailto) links are NOT
#     checked (this machine is offline): they are counted and listed in
#     <shots>/external-links.txt.
# It saves screenshots of the home page, the reference index and the
# "Your own data" article (its top and its first figure) in --shots (default
# site-check/), prints a summary, and exits non-zero on any failure.
#
# Offline builds: pkgdown downloads six JavaScript files from a CDN on its
# first build. When that fails, this script fetches them from the npm
# registry (`npm pack`) and keeps them only if their hashes are the ones
# pkgdown expects. bootstrap-toc is not on npm: then the copy pkgdown ships
# for its Bootstrap 3 template (an older version, same Toc.init() interface)
# stands in, and the summary says so. These files live in a cache of this
# script's own (R_USER_CACHE_DIR is pointed there), never in pkgdown's.
# KaTeX (template.math-rendering in _pkgdown.yml) is loaded by the pages
# themselves from a CDN: the script gets the same version from npm, checks
# its hash against the one in pkgdown's template, and the browser is served
# that copy for the CDN's addresses (the pages are not changed).

args <- commandArgs(trailingOnly = TRUE)
arg_value <- function(flag, default) {
  at <- match(flag, args)
  if (is.na(at)) default else args[[at + 1L]]
}
dest <- arg_value("--dest", "docs")
shots <- arg_value("--shots", "site-check")
for (d in c(dest, shots)) dir.create(d, recursive = TRUE, showWarnings = FALSE)
dest <- normalizePath(dest)
shots <- normalizePath(shots)
build <- !"--no-build" %in% args
lazy <- "--lazy" %in% args
screenshot_article <- "your-own-data"
`%||%` <- function(a, b) if (is.null(a)) b else a

for (p in c("pkgdown", "chromote", "jsonlite", "openssl")) {
  if (!requireNamespace(p, quietly = TRUE)) {
    stop("tools/check-site.R needs the ", p, " package: install.packages(\"", p, "\")")
  }
}
if (!file.exists("_pkgdown.yml")) stop("run tools/check-site.R from the package root")
pkgdown_minimum <- "2.1.2"
if (utils::packageVersion("pkgdown") < pkgdown_minimum) {
  stop("tools/check-site.R needs pkgdown >= ", pkgdown_minimum, " (installed: ",
       utils::packageVersion("pkgdown"), "): install.packages(\"pkgdown\")")
}
# pkgdown runs the help pages' examples with evaluate, which it only
# suggests: an older evaluate fails every example ("argument "expr" is
# missing"). The version pkgdown asks for, from its own DESCRIPTION:
evaluate_needed <- local({
  suggests <- utils::packageDescription("pkgdown")$Suggests %||% ""
  m <- regmatches(suggests, regexec("evaluate \\(>= ([0-9.]+)\\)", suggests))[[1]]
  if (length(m) == 2L) m[2] else "0"
})
if (!requireNamespace("evaluate", quietly = TRUE) ||
    utils::packageVersion("evaluate") < evaluate_needed) {
  stop("pkgdown ", utils::packageVersion("pkgdown"), " runs the examples with evaluate >= ",
       evaluate_needed, " (installed: ",
       tryCatch(format(utils::packageVersion("evaluate")), error = function(e) "none"),
       "): install.packages(\"evaluate\")")
}

# --- the installed griddy is the one this tree describes -------------------
check_installed_griddy <- function() {
  source_version <- read.dcf("DESCRIPTION", fields = "Version")[1, 1]
  installed <- tryCatch(as.character(utils::packageVersion("griddy")), error = function(e) NA)
  if (!isTRUE(installed == source_version)) {
    stop("installed griddy is ", installed, ", this tree is ", source_version,
         ": run `R CMD INSTALL .` first")
  }
  cat("griddy", installed, "from", find.package("griddy"), "\n")
}

# --- pkgdown's CDN assets, for a machine with no network --------------------
# The files pkgdown wants, read from pkgdown itself (its internal
# external_dependencies() with the downloader swapped for a recorder), so the
# list follows the installed pkgdown.
pkgdown_cdn_files <- function() {
  ns <- asNamespace("pkgdown")
  if (!exists("external_dependencies", ns) || !exists("cached_dependency", ns)) return(list())
  wanted <- list()
  recorder <- function(name, version, files) {
    for (f in files) wanted[[length(wanted) + 1L]] <<- c(name = name, version = version, f)
    NULL
  }
  lister <- get("external_dependencies", ns)
  environment(lister) <- list2env(list(cached_dependency = recorder), parent = ns)
  lister(pkg = NULL)
  wanted
}

file_integrity <- function(path, algorithm) {
  hash <- switch(algorithm, sha256 = openssl::sha256, sha384 = openssl::sha384,
                 sha512 = openssl::sha512)
  con <- file(path, "rb")
  on.exit(close(con))
  paste0(algorithm, "-", openssl::base64_encode(hash(con)))
}

# cdnjs names a library as its site does; npm as its publisher did.
npm_names <- c(headroom = "headroom.js", clipboard.js = "clipboard", fuse.js = "fuse.js",
               autocomplete.js = "autocomplete.js", mark.js = "mark.js")

fetch_from_npm <- function(url, target) {
  parts <- regmatches(url, regexec("ajax/libs/([^/]+)/([^/]+)/([^/]+)$", url))[[1]]
  if (length(parts) != 4L || is.na(npm_names[parts[2]]) || !nzchar(Sys.which("npm"))) return(FALSE)
  work <- tempfile("npm-")
  dir.create(work)
  on.exit(unlink(work, recursive = TRUE))
  spec <- paste0(npm_names[[parts[2]]], "@", parts[3])
  tarball <- system2("npm", c("pack", "--silent", "--pack-destination", work, spec),
                     stdout = TRUE, stderr = FALSE)
  tarball <- file.path(work, utils::tail(tarball, 1L))
  if (!length(tarball) || !file.exists(tarball)) return(FALSE)
  utils::untar(tarball, exdir = work)
  found <- list.files(work, pattern = paste0("^", gsub(".", "\\.", parts[4], fixed = TRUE), "$"),
                      recursive = TRUE, full.names = TRUE)
  found <- found[grepl("/dist/", found)]
  length(found) > 0L && file.copy(found[[1]], target, overwrite = TRUE)
}

fetch_asset <- function(f, target) {
  got <- suppressWarnings(tryCatch(
    utils::download.file(f[["url"]], target, quiet = TRUE, mode = "wb") == 0,
    error = function(e) FALSE)) || fetch_from_npm(f[["url"]], target)
  if (got && !has_integrity(target, f[["integrity"]])) unlink(target)
}

has_integrity <- function(path, integrity) {
  file.exists(path) && file_integrity(path, sub("-.*", "", integrity)) == integrity
}

# bootstrap-toc 1.0.1 gives its lists and links the Bootstrap 4/5 classes that
# pkgdown's stylesheet targets (`#toc > .nav a.nav-link`); the 0.4.1 that
# pkgdown ships for Bootstrap 3 does not, so the stand-in adds them.
toc_class_adapter <- "
/* Added by griddy's tools/check-site.R: offline stand-in for bootstrap-toc 1.0.1 */
(function () {
  var init = window.Toc.init;
  window.Toc.init = function (opts) {
    init.call(window.Toc, opts);
    var $nav = opts.jquery ? opts : opts.$nav;
    $nav.find('ul').addClass('nav navbar-nav');
    $nav.find('a').addClass('nav-link');
  };
})();"

write_toc_stand_in <- function(bs3_copy, target) {
  writeLines(c(readLines(bs3_copy), toc_class_adapter), target)
}

# Returns the assets that are stand-ins (not byte-identical to the CDN's).
fill_asset_cache <- function() {
  stand_ins <- character()
  for (f in pkgdown_cdn_files()) {
    dir <- file.path(tools::R_user_dir("pkgdown", "cache"), f[["name"]], f[["version"]])
    target <- file.path(dir, basename(f[["url"]]))
    dir.create(dir, recursive = TRUE, showWarnings = FALSE)
    if (!file.exists(target)) fetch_asset(f, target)
    if (has_integrity(target, f[["integrity"]])) next
    bs3_copy <- system.file("BS3", "assets", "bootstrap-toc.js", package = "pkgdown")
    if (f[["name"]] != "bootstrap-toc" || !nzchar(bs3_copy)) {
      stop("could not get ", f[["url"]], " (offline, and not on npm with pkgdown's hash)")
    }
    if (!file.exists(target)) write_toc_stand_in(bs3_copy, target)
    stand_ins <- c(stand_ins, paste(f[["name"]], f[["version"]], "stood in for by pkgdown's Bootstrap 3 copy"))
  }
  stand_ins
}

# --- KaTeX for the browser, offline ------------------------------------------
# The KaTeX files pkgdown's template loads: their CDN prefix and the SRI hash
# of katex.min.js, read from the installed pkgdown's template.
katex_cdn <- function() {
  head <- system.file("BS5", "templates", "head.html", package = "pkgdown")
  lines <- if (nzchar(head)) readLines(head, warn = FALSE) else character()
  js <- grep("katex@[0-9.]+/dist/katex\\.min\\.js", lines, value = TRUE)
  if (!length(js)) return(NULL)
  list(prefix = regmatches(js[1], regexpr("https://[^\"]*katex@[0-9.]+/dist/", js[1])),
       version = sub(".*katex@([0-9.]+)/.*", "\\1", js[1]),
       integrity = sub(".*integrity=\"([^\"]+)\".*", "\\1", js[1]))
}

# A local copy of KaTeX's dist/ folder, from npm, byte-identical to the CDN's
# (same hash as the template's); NULL when it cannot be had.
katex_local_copy <- function(cdn) {
  if (is.null(cdn)) return(NULL)
  dist <- file.path(cache_dir, "katex", cdn$version, "dist")
  if (!file.exists(file.path(dist, "katex.min.js")) && nzchar(Sys.which("npm"))) {
    work <- tempfile("npm-")
    dir.create(work)
    on.exit(unlink(work, recursive = TRUE))
    tarball <- system2("npm", c("pack", "--silent", "--pack-destination", work,
                                paste0("katex@", cdn$version)), stdout = TRUE, stderr = FALSE)
    tarball <- file.path(work, utils::tail(tarball, 1L))
    if (length(tarball) && file.exists(tarball)) {
      utils::untar(tarball, exdir = work)
      dir.create(dirname(dist), recursive = TRUE, showWarnings = FALSE)
      file.copy(file.path(work, "package", "dist"), dirname(dist), recursive = TRUE)
    }
  }
  if (has_integrity(file.path(dist, "katex.min.js"), cdn$integrity)) dist else NULL
}

content_types <- c(js = "application/javascript", css = "text/css", woff2 = "font/woff2",
                   woff = "font/woff", ttf = "font/ttf")

# Answer the browser's requests for the KaTeX CDN from the local copy; every
# other request goes on as usual.
serve_katex_locally <- function(session, cdn, dist) {
  session$Fetch$enable(patterns = list(list(urlPattern = paste0(cdn$prefix, "*"))))
  session$Fetch$requestPaused(callback_ = function(event) {
    url <- sub("[?#].*$", "", event$request$url)
    if (!startsWith(url, cdn$prefix)) {
      return(session$Fetch$continueRequest(requestId = event$requestId, wait_ = FALSE))
    }
    path <- file.path(dist, substring(url, nchar(cdn$prefix) + 1L))
    if (!file.exists(path)) {
      return(session$Fetch$failRequest(requestId = event$requestId, errorReason = "FileNotFound",
                                       wait_ = FALSE))
    }
    type <- content_types[tools::file_ext(path)]
    session$Fetch$fulfillRequest(
      requestId = event$requestId, responseCode = 200L,
      responseHeaders = list(
        list(name = "Content-Type", value = if (is.na(type)) "application/octet-stream" else unname(type)),
        list(name = "Access-Control-Allow-Origin", value = "*")),
      body = openssl::base64_encode(readBin(path, "raw", file.size(path)), linebreaks = FALSE),
      wait_ = FALSE)
  })
}

# pkgdown looks the package up on CRAN and Bioconductor for a "View on" link
# in the home page's sidebar, and stops when it cannot reach them. Offline,
# and griddy being on neither, that link is left out.
skip_repository_lookup_offline <- function() {
  ns <- asNamespace("pkgdown")
  if (!exists("cran_link", ns)) return(FALSE)
  reachable <- tryCatch({ get("cran_link", ns)("griddy"); TRUE }, error = function(e) FALSE)
  if (!reachable) utils::assignInNamespace("cran_link", function(pkg) NULL, "pkgdown")
  !reachable
}

# --- build -------------------------------------------------------------------
build_site <- function() {
  if (!lazy) unlink(dest, recursive = TRUE)
  pkgdown::build_site(".", install = FALSE, new_process = FALSE, preview = FALSE, lazy = lazy,
                      override = list(destination = dest))
}

# --- what a page shows in Chromium -----------------------------------------
page_facts_js <- "(async () => {
  await Promise.all(Array.from(document.images).map(i => i.complete ? null :
    new Promise(r => { i.addEventListener('load', r); i.addEventListener('error', r); })));
  const main = document.querySelector('main');
  const all = sel => Array.from(document.querySelectorAll(sel));
  return JSON.stringify({
    body_chars: document.body ? document.body.innerText.trim().length : 0,
    main_chars: main ? main.innerText.trim().length : 0,
    images: all('img').map(i => ({src: i.getAttribute('src'), url: i.src, width: i.naturalWidth})),
    links: all('a[href]').map(a => ({href: a.getAttribute('href'), url: a.href})),
    assets: all('link[rel=stylesheet][href], script[src]').map(e =>
      ({href: e.getAttribute('href') || e.getAttribute('src'), url: e.href || e.src})),
    ids: all('[id]').map(e => e.id).concat(all('a[name]').map(a => a.name)),
    raw_math: (() => {
      if (!main) return 0;
      const prose = main.cloneNode(true);
      prose.querySelectorAll('pre, code, .katex').forEach(e => e.remove());
      return (prose.textContent.match(/\\\\[(\\[]/g) || []).length;
    })(),
    r_errors: all('pre').map(p => p.innerText)
      .filter(t => /(^|\\n)(#>|##)?\\s*Error( in |:)/.test(t)).map(t => t.slice(0, 300)),
    r_warnings: all('pre').flatMap(p => p.innerText.split('\\n'))
      .filter(l => /^(#>|##)?\\s*Warning/.test(l)),
    readers: READER_CHECKS
  });
})()"
# what a reader sees wrong (wide tables, raw superscripts, lost captions):
# the checks tools/check-vignettes.R runs on the installed vignettes
page_facts_js <- sub("READER_CHECKS", paste(readLines("tools/reader-checks.js", encoding = "UTF-8"),
                                            collapse = "\n"),
                     page_facts_js, fixed = TRUE)

open_browser <- function() {
  if (!nzchar(Sys.getenv("CHROMOTE_CHROME")) && file.exists("/usr/bin/chromium")) {
    Sys.setenv(CHROMOTE_CHROME = "/usr/bin/chromium")
  }
  # chromote waits 10 s for the browser's debugging port by default; on a
  # loaded machine Chromium takes longer to start
  options(chromote.timeout = 60)
  session <- chromote::ChromoteSession$new(width = 1280, height = 1000)
  session$Runtime$enable()
  if (!is.null(katex_dist)) serve_katex_locally(session, katex, katex_dist)
  session
}

visit <- function(session, path) {
  exceptions <- character()
  stop_listening <- session$Runtime$exceptionThrown(callback_ = function(event) {
    d <- event$exceptionDetails
    exceptions <<- c(exceptions, d$exception$description %||% d$text)
  })
  on.exit(stop_listening())
  session$go_to(paste0("file://", path))
  result <- session$Runtime$evaluate(page_facts_js, awaitPromise = TRUE, returnByValue = TRUE)
  facts <- jsonlite::fromJSON(result$result$value, simplifyVector = FALSE)
  facts$exceptions <- exceptions
  facts
}

# --- link resolution ---------------------------------------------------------
# "file:///x/y.html#frag" -> list(path, fragment), or NULL for an external URL.
local_target <- function(url) {
  if (!startsWith(url, "file://")) return(NULL)
  fragment <- if (grepl("#", url, fixed = TRUE)) sub("^[^#]*#", "", url) else ""
  path <- utils::URLdecode(sub("[?#].*$", "", sub("^file://", "", url)))
  if (dir.exists(path)) path <- file.path(path, "index.html")
  list(path = normalizePath(path, mustWork = FALSE), fragment = utils::URLdecode(fragment))
}

check_reference <- function(ref, page, kind, ids_by_page) {
  target <- local_target(ref$url)
  if (is.null(target)) return(NULL)
  in_site <- startsWith(target$path, paste0(dest, "/"))
  if (!in_site || !file.exists(target$path) || file.size(target$path) == 0) {
    return(sprintf("%s: broken %s %s (no such file in the site)", page, kind, ref$href))
  }
  if (nzchar(target$fragment) && kind == "link") {
    ids <- ids_by_page[[target$path]]
    if (is.null(ids) && grepl("\\.html$", target$path)) {
      ids <- xml2::xml_attr(xml2::xml_find_all(xml2::read_html(target$path), "//*[@id]"), "id")
    }
    if (!target$fragment %in% ids) {
      return(sprintf("%s: broken anchor %s (no id \"%s\" on the target page)",
                     page, ref$href, target$fragment))
    }
  }
  NULL
}

page_failures <- function(facts, page) {
  failures <- character()
  if (facts$body_chars == 0 || facts$main_chars == 0) {
    failures <- c(failures, sprintf("%s: empty page", page))
  }
  for (e in facts$exceptions) failures <- c(failures, sprintf("%s: JavaScript exception: %s", page, e))
  for (e in facts$r_errors) failures <- c(failures, sprintf("%s: R error in output: %s", page, e))
  if (isTRUE(facts$raw_math > 0)) {
    failures <- c(failures, sprintf("%s: maths not rendered: %d formula(s) shown as LaTeX",
                                    page, facts$raw_math))
  }
  for (img in facts$images) {
    if (img$width == 0) failures <- c(failures, sprintf("%s: image does not load: %s", page, img$src))
  }
  what <- c(wide_tables = "table wider than the text", raw_superscripts = "raw superscript",
            alt_only_captions = "figure caption only in alt text",
            stray_captions = "table caption left as text", odd_mailto = "mailto: link in text")
  for (k in names(what)) {
    for (e in unlist(facts$readers[[k]])) failures <- c(failures, sprintf("%s: %s: %s", page, what[[k]], e))
  }
  failures
}

# --- screenshots -------------------------------------------------------------
take_screenshots <- function(session) {
  dir.create(shots, recursive = TRUE, showWarnings = FALSE)
  shoot <- function(page, file, ...) {
    session$go_to(paste0("file://", file.path(dest, page)))
    session$screenshot(file.path(shots, file), show = FALSE, ...)
    file.path(shots, file)
  }
  article <- file.path("articles", paste0(screenshot_article, ".html"))
  c(shoot("index.html", "home.png", cliprect = c(0, 0, 1280, 1800)),
    shoot(file.path("reference", "index.html"), "reference-index.png", cliprect = c(0, 0, 1280, 2400)),
    shoot(article, paste0("article-", screenshot_article, ".png"), cliprect = c(0, 0, 1280, 1800)),
    shoot_first_figure(session, article, paste0("article-", screenshot_article, "-figure.png")))
}

first_figure_js <- "(() => { const r = document.querySelector('main img').getBoundingClientRect();
  return JSON.stringify([r.top + window.scrollY, r.height]); })()"

# The first figure of a page with the text around it, in page coordinates.
shoot_first_figure <- function(session, page, file) {
  session$go_to(paste0("file://", file.path(dest, page)))
  box <- jsonlite::fromJSON(session$Runtime$evaluate(first_figure_js, returnByValue = TRUE)$result$value)
  session$screenshot(file.path(shots, file), show = FALSE,
                     cliprect = c(0, max(0, box[1] - 300), 1280, box[2] + 500))
  file.path(shots, file)
}

# --- run ---------------------------------------------------------------------
cache_dir <- tools::R_user_dir("griddy-site-check", "cache")
Sys.setenv(R_USER_CACHE_DIR = cache_dir)
stand_ins <- character()
if (build) {
  check_installed_griddy()
  stand_ins <- fill_asset_cache()
  if (skip_repository_lookup_offline()) stand_ins <- c(stand_ins, "no CRAN/Bioconductor look-up")
  build_site()
}
katex <- if (any(grepl("^\\s*math-rendering:\\s*katex", readLines("_pkgdown.yml")))) katex_cdn()
katex_dist <- katex_local_copy(katex)
if (!is.null(katex_dist)) {
  stand_ins <- c(stand_ins, paste("KaTeX", katex$version, "served from its npm package (same hash)"))
}
pages <- normalizePath(list.files(dest, pattern = "\\.html$", recursive = TRUE, full.names = TRUE))
if (!length(pages)) stop("no pages in ", dest)

session <- open_browser()
facts <- lapply(pages, function(p) visit(session, p))
names(facts) <- pages

# Every failure, the R warnings shown, the external URLs (with the pages that
# link them) and the counts, over all pages.
check_pages <- function(facts) {
  ids_by_page <- lapply(facts, `[[`, "ids")
  out <- list(failures = character(), notes = character(), external = list(),
              images = 0L, internal = 0L, external_refs = 0L, assets = 0L)
  for (path in names(facts)) {
    page <- substring(path, nchar(dest) + 2L)
    f <- facts[[path]]
    out$failures <- c(out$failures, page_failures(f, page))
    out$notes <- c(out$notes, sprintf("%s: %s", page, strtrim(unlist(f$r_warnings), 160)))
    out$images <- out$images + length(f$images)
    out$assets <- out$assets + length(f$assets)
    refs <- c(lapply(f$links, c, kind = "link"), lapply(f$assets, c, kind = "asset"))
    for (ref in refs) {
      if (grepl("^(https?:|mailto:)", ref$url)) {
        out$external[[ref$url]] <- union(out$external[[ref$url]], page)
        if (ref$kind == "link") out$external_refs <- out$external_refs + 1L
      } else if (!grepl("^javascript:", ref$url)) {
        if (ref$kind == "link") out$internal <- out$internal + 1L
        out$failures <- c(out$failures, check_reference(ref, page, ref$kind, ids_by_page))
      }
    }
  }
  out
}

checked <- check_pages(facts)
screenshots <- take_screenshots(session)
invisible(session$close())

external <- checked$external
writeLines(vapply(names(external), function(u) paste0(u, "\t", paste(external[[u]], collapse = " ")), ""),
           file.path(shots, "external-links.txt"))

cat("\n== Site check ==\n")
cat(sprintf("site:        %s\n", dest))
cat(sprintf("pages:       %d opened in headless Chromium\n", length(pages)))
cat(sprintf("images:      %d (each must have naturalWidth > 0)\n", checked$images))
cat(sprintf("links:       %d internal <a href> checked (file and #anchor), %d stylesheets/scripts\n",
            checked$internal, checked$assets))
cat(sprintf("external:    %d links to %d distinct URLs NOT checked (offline), listed in %s\n",
            checked$external_refs, length(external), file.path(shots, "external-links.txt")))
if (length(stand_ins)) {
  cat(sprintf("offline:     %s\n", paste(stand_ins, collapse = "; ")))
}
cat("screenshots:", paste(screenshots, collapse = "\n             "), "\n")
if (length(checked$notes)) {
  cat(sprintf("\nNote: %d R warning(s) shown in output blocks (not failures):\n", length(checked$notes)))
  cat(paste0("  - ", checked$notes), sep = "\n")
}
if (length(checked$failures)) {
  cat(sprintf("\nFAILED: %d problem(s)\n", length(unique(checked$failures))))
  cat(paste0("  - ", unique(checked$failures)), sep = "\n")
  quit(status = 1)
}
cat("\nAll pages render, all images load, no internal link is broken.\n")
