#!/usr/bin/env bash
# plan.md (session 35, added after the selection; descriptive, nothing is picked from it): the 10-decision
# validation gap_closed of em_choice_long's snapshots against training wall-clock (issue 24's curve), as
# em_choice_long.sh's validation (cached baselines, frozen session-32 code). Update 0 is the previous default
# and update 825 the shipped policy, both measured before.
set -e
cd /work/train_code32
export PYTHONPATH=/work/train_code32
OFFICE="--layouts 1000 1001 1002 1003 1004 1005 1006 1007 1008 1009 --starts 3 --max-decisions 10 --workers 2 --set graph.features=extended"
BUILD="--scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --workers 2 --set graph.features=extended"
LOTS="$BUILD scene.building.lot_probability=1"
SPARSE="$LOTS scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
for update in 00080 00160 00240 00400 00560 00720; do
  PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --policy /work/runs/em_choice_long/checkpoints/update_$update.pt"
  for kind in office building lots sparse; do
    out=/work/runs/val/$kind/em_choice_long_u$update
    mkdir -p $out
    cp /work/runs/val/$kind/dagger_sparse_last/episodes.jsonl $out/
    args=$OFFICE; [ $kind = building ] && args=$BUILD; [ $kind = lots ] && args=$LOTS; [ $kind = sparse ] && args=$SPARSE
    echo "== em_choice_long update $update $kind"
    $PY $args --out $out
  done
done
echo "== done"
