#!/usr/bin/env bash
# plan.md: keep the trials of run.sh (and nearest.sh, where it ran) in runs/, then the figure of record
# (study_zero_shot.py, pooled over every building both policies finished) and the association of the map-error
# ratio with the loop-closure and travel ratios (association.py); the nearest-frontier yardstick the same way.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
PY=${PY:-/work/main/.venv/bin/python}
STUDY=$HERE/../../study_zero_shot.py
source $HERE/../keep.sh  # keep SRC DST
for s in even odd; do
  keep /work/runs/zs_b100/$s $HERE/runs/$s
  keep /work/runs/zs_b100_nearest/$s $HERE/runs_nearest/$s
done
$PY $STUDY $HERE/runs/even $HERE/runs/odd --pool all_100 --out $HERE/targets > $HERE/study.log
$PY $HERE/association.py $HERE/runs/even $HERE/runs/odd > $HERE/association.log
if [ -d $HERE/runs_nearest ]; then
  $PY $STUDY $HERE/runs_nearest/even $HERE/runs_nearest/odd --policy nearest --reference $HERE/runs/even \
    $HERE/runs/odd --pool all_nearest --out $HERE/targets_nearest > $HERE/study_nearest.log
  $PY $HERE/association.py $HERE/runs_nearest/even $HERE/runs_nearest/odd $HERE/runs/even $HERE/runs/odd \
    --policy nearest > $HERE/association_nearest.log
fi
# the shipped policy on the buildings the yardstick finished, for a like-for-like row (trials read from runs/)
if [ -d $HERE/runs_nearest ]; then
  for s in even odd; do
    SUBSET=""
    for d in $HERE/runs_nearest/$s/*_building_*/; do SUBSET="$SUBSET $HERE/runs/$s/$(basename $d)"; done
    rm -rf $HERE/subset_nearest/$s && mkdir -p $HERE/subset_nearest/$s && cp -r $SUBSET $HERE/subset_nearest/$s/
  done
  $PY $STUDY $HERE/subset_nearest/even $HERE/subset_nearest/odd --pool all_nearest_subset \
    --out $HERE/targets_nearest_subset > $HERE/study_nearest_subset.log
  rm -rf $HERE/subset_nearest  # copies of runs/, not kept
fi
# secondary (plan.md): the 20 earlier held-out buildings (session 35's trials of the shipped policy, frozen
# session-32 code, paired with EM's of zero_shot_v5_20) pooled with these 100; the 100's learned trials go in a
# learned-only copy, since study_zero_shot.py pairs a report with --reference only when it holds no EM trials
rm -rf $HERE/learned_only
for s in even odd; do
  for d in $HERE/runs/$s/*_building_*/; do
    mkdir -p $HERE/learned_only/$s/$(basename $d)
    grep '"policy": "learned"' $d/trials.jsonl > $HERE/learned_only/$s/$(basename $d)/trials.jsonl
  done
done
$PY $STUDY $HERE/../selection_v6/zero_shot_runs/buildings $HERE/learned_only/even $HERE/learned_only/odd \
  --reference $HERE/../zero_shot_v5_20/buildings $HERE/runs/even $HERE/runs/odd --pool all_120 \
  --out $HERE/targets_120 > $HERE/study_120.log
rm -rf $HERE/learned_only  # copies of runs/, not kept
