# Sourced by the setup chunk of the vignettes with captioned figures or
# tables. R CMD build renders the vignettes with knitr's engine, which
# without rmarkdown (not a dependency) hands the Markdown to litedown; the
# site (pkgdown) hands it to Pandoc. Knitr writes captions the way Pandoc
# reads them, and litedown loses or misplaces them:
#
# * A figure: knitr writes ![caption](file), which litedown renders as an
#   image whose caption is only its alt text, unless the chunk sizes the
#   figure (out.width), when knitr writes the image and its caption in HTML.
#   So a captioned figure gets out.width = "100%" (Pandoc renders that HTML
#   too). A figure with no caption and out.width would show knitr's
#   placeholder "plot of chunk <label>" as its caption: it gets an empty one.
# * A table: knitr::kable() writes the caption as a "Table: ..." paragraph
#   before the table; litedown takes a caption from the paragraph after a
#   table, so each caption would land on the table above it. Pandoc reads
#   either side: the caption is moved after the table.
#
# knitr restores its chunk options after each vignette but not its option
# hooks: in one R session (R CMD build renders all the vignettes in one) the
# hooks stay for the vignettes rendered after, where they touch only
# captioned or sized figures, which they treat the same way.
knitr::opts_hooks$set(
  fig.cap = function(options) {
    if (any(nzchar(options$fig.cap)) && is.null(options$out.width)) options$out.width <- "100%"
    options
  },
  out.width = function(options) {
    if (is.null(options$fig.cap)) options$fig.cap <- ""
    options
  })
knitr::opts_chunk$set(render = function(x, options, ...) {
  if (inherits(x, "knitr_kable") && length(x) > 2L && startsWith(x[[1]], "Table: ")) {
    x[] <- c(x[-(1:2)], "", x[[1]])
  }
  knitr::knit_print(x, options = options, ...)
})
