#!/usr/bin/env bash
# Session 76: on a new machine, put named200_s76.sh's kept work back into /work/runs/stop85_named200_em (OUT) so the
# driver resumes it: each chunk of 25 seeds whose trials are all in runs/named200_em becomes a finished chunk again
# (its trials.jsonl, which the driver skips), and the unfinished chunks of partial/stop85_named200_em are copied
# back (explore-rl-eval resumes them trial by trial). Then: bash named200_s76.sh, and bash named200_keep_s76.sh.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
OUT=${OUT:-/work/runs/stop85_named200_em}
mkdir -p $OUT
for pair in 0_street:street 1_garage:garage; do
  folder=${pair%%:*}; scene=${pair##*:}
  kept=$HERE/runs/named200_em/$folder/trials.jsonl
  [ -e $kept ] || continue
  for FIRST in 50 75 100 125 150 175; do
    dir=$OUT/${scene}_seeds_$FIRST/0_$scene
    $PY - $kept $FIRST $dir <<'PY'
import json, sys
from pathlib import Path
kept, first, out = Path(sys.argv[1]), int(sys.argv[2]), Path(sys.argv[3])
lines = [line for line in kept.read_text().splitlines() if first <= json.loads(line)["seed"] < first + 25]
if len(lines) == 25:  # the whole chunk was kept
    out.mkdir(parents=True, exist_ok=True)
    (out / "trials.jsonl").write_text("\n".join(lines) + "\n")
PY
  done
done
[ -d $HERE/partial/stop85_named200_em ] && cp -rn $HERE/partial/stop85_named200_em/* $OUT/
ls $OUT
