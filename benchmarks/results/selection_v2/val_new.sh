#!/usr/bin/env bash
# Validation of the office-DAgger candidate (code d04388d), baselines from the cache of the buildings_distill run.
cd /work/train_code
export PYTHONPATH=/work/train_code
while pgrep -f "explore-rl-train scene=office" > /dev/null; do sleep 10; done
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py"
OFFICE="--layouts 1000 1001 1002 1003 1004 1005 1006 1007 1008 1009 --starts 3 --max-decisions 10 --set graph.features=extended --workers 2"
BUILD="--scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --set graph.features=extended --workers 2"
for name in last update_00080; do
  for kind in office building; do
    [ $name = update_00080 ] && [ $kind = building ] && continue
    mkdir -p /work/runs/val/$kind/dagger_office_$name
    cp /work/runs/val/$kind/buildings_distill/episodes.jsonl /work/runs/val/$kind/dagger_office_$name/
    args=$OFFICE; [ $kind = building ] && args=$BUILD
    $PY --policy /work/runs/dagger_office/checkpoints/$name.pt $args --out /work/runs/val/$kind/dagger_office_$name
  done
done
