#!/usr/bin/env bash
# Validation (office, buildings, lots, sparse lots) of the sparse-lot DAgger candidates; baselines from
# the caches of earlier validations (same episodes for every candidate).
cd /work/train_code32
export PYTHONPATH=/work/train_code32
while pgrep -f "explore-rl-train scene=building" > /dev/null; do sleep 10; done
while pgrep -f "val_sparse_base" > /dev/null; do sleep 10; done
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py"
OFFICE="--layouts 1000 1001 1002 1003 1004 1005 1006 1007 1008 1009 --starts 3 --max-decisions 10 --set graph.features=extended --workers 2"
BUILD="--scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --workers 2 --set graph.features=extended"
LOTS="$BUILD scene.building.lot_probability=1"
SPARSE="$LOTS scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
updates=$(tail -1 /work/runs/dagger_sparse/logs/a2c/scalars/updates.csv | cut -d, -f2 | cut -d. -f1)
mid=$(ls /work/runs/dagger_sparse/checkpoints | grep update_ | sed 's/update_0*//; s/.pt//' | awk -v h=$((updates / 2)) '$1 <= h' | sort -n | tail -1)
mid=$(printf "update_%05d" $mid)
echo "updates $updates, mid-run candidate $mid"
for name in last $mid; do
  for kind in sparse lots building office; do
    out=/work/runs/val/$kind/dagger_sparse_$name
    mkdir -p $out
    base=/work/runs/val/$kind/buildings_distill/episodes.jsonl
    [ $kind = lots ] && base=/work/runs/val/lots/buildings_office_distill/episodes.jsonl
    [ $kind = sparse ] && base=/work/runs/val/sparse/buildings_lots_distill/episodes.jsonl
    cp $base $out/
    args=$OFFICE; [ $kind = building ] && args=$BUILD; [ $kind = lots ] && args=$LOTS; [ $kind = sparse ] && args=$SPARSE
    echo "== $name $kind"
    $PY --policy /work/runs/dagger_sparse/checkpoints/$name.pt $args --out $out
  done
done
