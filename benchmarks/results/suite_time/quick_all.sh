#!/usr/bin/env bash
# The --quick of every benchmark and study script that has one (after a refactor, ground rules): one line per
# script with its exit code, wall seconds and the JSON line it printed last. OUT: the log (default stdout).
cd "$(dirname "$0")/../../.."
for script in benchmarks/bench_*.py benchmarks/study_*.py benchmarks/sweep_alpha.py; do
  grep -q -- '--quick' $script || continue
  name=$(basename $script .py)
  start=$(date +%s)
  out=$(mktemp)
  .venv/bin/python $script --quick > $out 2>/dev/null
  rc=$?
  last=$(grep '^{' $out | tail -1); rm -f $out
  echo "$name rc=$rc $(( $(date +%s) - start ))s ${last:0:300}"
done > ${OUT:-/dev/stdout}
