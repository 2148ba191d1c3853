#!/usr/bin/env bash
# Validation parking lots (building seeds 1000-1004 as lot plans, 4 starts, 10 decisions):
# EM, random, nearest and the shipped buildings_office_distill; the cache is reused by later candidates.
cd /work/train_code32
export PYTHONPATH=/work/train_code32
mkdir -p /work/runs/val/lots/buildings_office_distill
exec nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py \
  --policy /work/main/policies/buildings_office_distill/actor.pt --scene building \
  --set graph.features=extended scene.building.lot_probability=1 \
  --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --workers 1 \
  --out /work/runs/val/lots/buildings_office_distill
