// What a reader sees wrong on a rendered page: one JavaScript expression whose
// value is an object of lists (empty lists: nothing wrong). Read by
// tools/check-site.R (the pkgdown site, through chromote) and
// tools/check-vignettes.R (the installed vignettes, through Chromium's
// --dump-dom); both report every entry as a failure.
//   wide_tables:       tables wider than the text column (cut, or scrolled
//                      sideways), by their first headers;
//   raw_superscripts:  Pandoc's x^y^ left as text (litedown renders only
//                      letters and digits between the carets);
//   alt_only_captions: a figure whose caption is only its alt text (knitr
//                      wrote ![caption](file), and litedown shows no caption);
//   stray_captions:    a "Table: ..." paragraph left as text (a table's
//                      caption the renderer did not attach);
//   odd_mailto:        a mailto: link whose text is not an address (Markdown
//                      autolinked text that merely contains an @).
(() => {
  const root = document.querySelector('main') || document.body;
  const all = sel => Array.from(root.querySelectorAll(sel));
  const clip = s => s.replace(/\s+/g, ' ').trim().slice(0, 80);
  const pad = getComputedStyle(root);
  const column = root.clientWidth - parseFloat(pad.paddingLeft) - parseFloat(pad.paddingRight);
  const wide_tables = all('table')
    .filter(t => t.getBoundingClientRect().width > column + 1)
    .map(t => Math.round(t.getBoundingClientRect().width) + ' px in ' + column + ' px: ' +
      clip(Array.from(t.querySelectorAll('th')).slice(0, 4).map(h => h.textContent).join(' | ')));
  const raw_superscripts = [];
  const walker = document.createTreeWalker(root, NodeFilter.SHOW_TEXT);
  for (let n = walker.nextNode(); n; n = walker.nextNode()) {
    if (n.parentElement.closest('pre, code, script, style, .katex, math')) continue;
    const hits = n.textContent.match(/[^\s^]\^[^\s^]+\^/g);
    if (hits) raw_superscripts.push(...hits);
  }
  const knitr_figure = i => /^data:image|figure-html|_files\//.test(i.getAttribute('src') || '');
  const alt_only_captions = all('img')
    .filter(i => knitr_figure(i) && i.alt && !/^plot of chunk /.test(i.alt))
    .filter(i => {
      const box = i.closest('figure, .figure');
      const cap = box && box.querySelector('figcaption, .caption');
      return !(cap && cap.textContent.trim());
    })
    .map(i => clip(i.alt));
  const stray_captions = all('p')
    .filter(p => /^Table:/.test(p.textContent.trim()))
    .map(p => clip(p.textContent));
  const odd_mailto = all('a[href^="mailto:"]')
    .filter(a => !/^[^\s@]+@[^\s@]+\.[A-Za-z]{2,}$/.test(a.textContent.trim()))
    .map(a => clip(a.parentElement.textContent));
  return {wide_tables, raw_superscripts, alt_only_captions, stray_captions, odd_mailto};
})()
