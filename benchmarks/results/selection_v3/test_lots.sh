#!/usr/bin/env bash
# Held-out parking lots (building seeds 2000-2004 as lot plans x 4 starts): the new default, then the
# previous one on the same episodes (baselines from the cache of the first run).
cd /work/train_code32
export PYTHONPATH=/work/train_code32
ARGS="--scene building --layouts 2000 2001 2002 2003 2004 --starts 4 --max-decisions 10 --set graph.features=extended scene.building.lot_probability=1 --workers 2"
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py"
mkdir -p /work/runs/test32/lots_new /work/runs/test32/lots_old
$PY --policy /work/runs/ship32/actor.pt $ARGS --out /work/runs/test32/lots_new
cp /work/runs/test32/lots_new/episodes.jsonl /work/runs/test32/lots_old/
$PY --policy /work/main/policies/buildings_office_distill/actor.pt $ARGS --out /work/runs/test32/lots_old
