#!/usr/bin/env bash
# plan.md's amendment: the held-out test of the wide candidate, once, on test33's episodes (cached baselines),
# with the paired difference to the shipped default; code frozen at the session-32 start.
cd /work/train_code32
export PYTHONPATH=/work/train_code32
PY="nice -n 5 /work/main/.venv/bin/python /work/main/benchmarks/study_learning.py --policy /work/runs/wide_s33/actor.pt --compare /work/main/policies/buildings_sparse_distill/actor.pt --max-decisions 10 --workers 2 --set graph.features=extended"
$PY --layouts 2000 2001 --starts 9 --out /work/runs/test33/office
$PY --scene building --layouts 2000 2001 2002 2003 2004 --starts 4 --out /work/runs/test33/building
