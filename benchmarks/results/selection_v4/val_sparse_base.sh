#!/usr/bin/env bash
# Validation sparse parking lots (building seeds 1000-1004 as large sparse lot plans, 4 starts, 10 decisions):
# EM, random, nearest and the new default buildings_lots_distill; the cache is reused by later candidates.
cd /work/train_code32
export PYTHONPATH=/work/train_code32
mkdir -p /work/runs/val/sparse/buildings_lots_distill
exec nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py \
  --policy /work/main/policies/buildings_lots_distill/actor.pt --scene building \
  --set graph.features=extended scene.building.lot_probability=1 scene.building.size_min=28.0 \
  scene.building.size_max=35.0 "scene.building.lot_lane_width=[6.5,7.0]" "scene.building.lot_car_pitch=[6.0,6.5]" \
  scene.building.lot_gap_probability=0.5 \
  --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --workers 1 \
  --out /work/runs/val/sparse/buildings_lots_distill
