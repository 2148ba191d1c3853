#!/usr/bin/env bash
# Held-out test (run once, after selection on validation) of the office-DAgger actor, code d04388d.
cd /work/train_code
export PYTHONPATH=/work/train_code
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --policy /work/runs/ship/actor.pt --max-decisions 10 --set graph.features=extended --workers 2"
$PY --layouts 2000 2001 --starts 9 --out /work/runs/test/office
$PY --scene building --layouts 2000 2001 2002 2003 2004 --starts 4 --out /work/runs/test/building
