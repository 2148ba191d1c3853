#!/usr/bin/env bash
# Session 75 (plan.md's addendum): EM against itself on the 90 validation buildings 1010-1099, the protocol's noise
# floor there. Keeps EM's second trials (dagger_s74.sh em_replicate, /work/runs/stop85_em_replicate_val90) in
# runs/em_replicate_val90, then pairs them building by building with EM's stored first trials of runs/val (1010-1039)
# and runs/val2 (1040-1099): study_zero_shot.py --policy em --reference-policy em, pooled over the buildings both have
# (em_replicate_val90.log, targets_em_replicate_val90).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
keep /work/runs/stop85_em_replicate_val90 $HERE/runs/em_replicate_val90
SPLIT=$(mktemp -d)
split_by_reference $SPLIT $HERE/runs/em_replicate_val90 $HERE/runs val val2
$PY $RESULTS/../study_zero_shot.py $SPLIT/val $SPLIT/val2 --reference $HERE/runs/val $HERE/runs/val2 \
  --policy em --reference-policy em --pool em_replicate_val90 --out $HERE/targets_em_replicate_val90 \
  > $HERE/em_replicate_val90.log
rm -rf $SPLIT
