#!/usr/bin/env bash
# Validation (office 1000-1009 x 3, buildings 1000-1004 x 4, parking lots 1000-1004 x 4) of the
# lot-DAgger candidates; baselines (EM, random, nearest) from the caches of earlier validations.
cd /work/train_code32
export PYTHONPATH=/work/train_code32
while pgrep -f "explore-rl-train scene=building" > /dev/null; do sleep 10; done
while pgrep -f "val_lots_base" > /dev/null; do sleep 10; done
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py"
OFFICE="--layouts 1000 1001 1002 1003 1004 1005 1006 1007 1008 1009 --starts 3 --max-decisions 10 --set graph.features=extended --workers 2"
BUILD="--scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --set graph.features=extended --workers 2"
LOTS="--scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --set graph.features=extended scene.building.lot_probability=1 --workers 2"
# the mid-run candidate: the last snapshot at or before half of the run's updates
updates=$(tail -1 /work/runs/dagger_lots/logs/a2c/scalars/updates.csv | cut -d, -f2 | cut -d. -f1)
mid=$(ls /work/runs/dagger_lots/checkpoints | grep update_ | sed 's/update_0*//; s/.pt//' | awk -v h=$((updates / 2)) '$1 <= h' | sort -n | tail -1)
mid=$(printf "update_%05d" $mid)
echo "updates $updates, mid-run candidate $mid"
for name in last $mid; do
  for kind in lots building office; do
    out=/work/runs/val/$kind/dagger_lots_$name
    mkdir -p $out
    base=/work/runs/val/$kind/buildings_distill/episodes.jsonl
    [ $kind = lots ] && base=/work/runs/val/lots/buildings_office_distill/episodes.jsonl
    cp $base $out/
    args=$OFFICE; [ $kind = building ] && args=$BUILD; [ $kind = lots ] && args=$LOTS
    echo "== $name $kind"
    $PY --policy /work/runs/dagger_lots/checkpoints/$name.pt $args --out $out
  done
done
