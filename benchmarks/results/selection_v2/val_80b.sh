#!/usr/bin/env bash
cd /work/train_code
export PYTHONPATH=/work/train_code
mkdir -p /work/runs/val/building/dagger_office_update_00080
cp /work/runs/val/building/buildings_distill/episodes.jsonl /work/runs/val/building/dagger_office_update_00080/
nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --policy /work/runs/dagger_office/checkpoints/update_00080.pt \
  --scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --set graph.features=extended --workers 2 \
  --out /work/runs/val/building/dagger_office_update_00080
