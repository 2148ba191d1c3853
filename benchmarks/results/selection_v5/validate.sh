#!/usr/bin/env bash
# plan.md: the wide candidate on selection_v4's four validation sets; baselines from their caches (code frozen
# at the session-32 start, so the same episodes and the same keys).
cd /work/train_code32
export PYTHONPATH=/work/train_code32
while pgrep -f "selection_v5/train.sh" > /dev/null; do sleep 10; done
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --policy /work/runs/wide_s33/actor.pt"
OFFICE="--layouts 1000 1001 1002 1003 1004 1005 1006 1007 1008 1009 --starts 3 --max-decisions 10 --workers 2 --set graph.features=extended"
BUILD="--scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --workers 2 --set graph.features=extended"
LOTS="$BUILD scene.building.lot_probability=1"
SPARSE="$LOTS scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
for kind in office building lots sparse; do
  out=/work/runs/val/$kind/wide_s33
  mkdir -p $out
  cp /work/runs/val/$kind/dagger_sparse_last/episodes.jsonl $out/
  args=$OFFICE; [ $kind = building ] && args=$BUILD; [ $kind = lots ] && args=$LOTS; [ $kind = sparse ] && args=$SPARSE
  echo "== wide_s33 $kind"
  $PY $args --out $out
done
