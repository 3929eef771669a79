#!/bin/sh
# How long R CMD build spends on the vignettes (issue 36 item 5): each
# vignette knitted in its own R process against an installed griddy, its
# CPU time (user + system, which the machine's load inflates far less than
# the elapsed time) and elapsed time, then the whole `R CMD build`.
# Usage, from the package root: sh bench/build-time.sh [library]
# (library: where griddy is installed; default: R's own).
lib=${1:-}
out=bench/results/build-time.csv
src=$(pwd)
tmp=$(mktemp -d)
cp -r vignettes "$tmp/"
echo "vignette,cpu_seconds,elapsed_seconds,load" > "$out"
for f in "$tmp"/vignettes/*.Rmd; do
  name=$(basename "$f" .Rmd)
  cd "$tmp/vignettes"
  /usr/bin/time -f "%U %S %e" -o "$tmp/time" env ${lib:+R_LIBS=$lib} Rscript -e \
    "tools::buildVignette('$name.Rmd', quiet = TRUE, clean = TRUE, tangle = FALSE)" \
    > "$tmp/$name.log" 2>&1 || echo "$name failed: see $tmp/$name.log"
  cd "$src"
  read u s e < "$tmp/time"
  echo "$name,$(echo "$u + $s" | bc),$e,$(cut -d' ' -f1 /proc/loadavg)" >> "$out"
done
cd "$tmp"
start=$(date +%s)
/usr/bin/time -f "%U %S %e" -o "$tmp/build-time" R CMD build "$src" > "$tmp/build.log" 2>&1
read u s e < "$tmp/build-time"
cd "$src"
echo "R CMD build,$(echo "$u + $s" | bc),$e,$(cut -d' ' -f1 /proc/loadavg)" >> "$out"
cat "$out"
