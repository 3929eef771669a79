# Sourced by the setup chunk of the vignettes whose tables have captions.
#
# knitr::kable() writes a table's caption as a "Table: ..." paragraph before
# the table. litedown, which renders the installed vignettes (knitr's engine
# without rmarkdown), takes a caption from the paragraph *after* a table, so
# each caption would land on the table above it, and the first would stay a
# paragraph. Pandoc, which renders the site, reads a caption on either side:
# moving it after the table suits both.
knitr::opts_chunk$set(render = function(x, options, ...) {
  if (inherits(x, "knitr_kable") && length(x) > 2L && startsWith(x[[1]], "Table: ")) {
    x[] <- c(x[-(1:2)], "", x[[1]])
  }
  knitr::knit_print(x, options = options, ...)
})
