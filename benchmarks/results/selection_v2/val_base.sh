#!/usr/bin/env bash
# Validation of the current default (buildings_distill) with code d04388d; its cache holds the baselines.
cd /work/train_code
export PYTHONPATH=/work/train_code
PY="nice -n 12 /work/main/.venv/bin/python benchmarks/study_learning.py"
$PY --policy /work/main/policies/buildings_distill/actor.pt --layouts 1000 1001 1002 1003 1004 1005 1006 1007 1008 1009 \
  --starts 3 --max-decisions 10 --set graph.features=extended --out /work/runs/val/office/buildings_distill
$PY --policy /work/main/policies/buildings_distill/actor.pt --scene building --layouts 1000 1001 1002 1003 1004 \
  --starts 4 --max-decisions 10 --set graph.features=extended --out /work/runs/val/building/buildings_distill
