#!/usr/bin/env bash
# Stops the Slurm and munge daemons that tools/slurm-start.sh started (by
# the pids in their pid files), and only those.
set -u
state=${GRIDDY_SLURM_STATE:-/run/griddy-slurm}
[ -f "$state/pidfiles" ] || exit 0
# slurmd first, munged last: the reverse of their start
for f in $(tac "$state/pidfiles"); do
  [ -s "$f" ] || continue
  pid=$(cat "$f")
  kill "$pid" 2>/dev/null || continue
  for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
done
rm -f "$state/pidfiles"
