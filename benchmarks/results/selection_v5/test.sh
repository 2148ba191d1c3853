#!/usr/bin/env bash
# plan.md's amendment: the held-out test of the wide candidate, once, on test33's episodes (cached baselines),
# the default's figures on the same episodes are in its own test; code frozen at the session-32 start.
cd /work/train_code32
export PYTHONPATH=/work/train_code32
# the frozen copy of the script (main's --compare needs main's evaluate module, whose new source digest would miss the caches)
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --policy /work/runs/wide_s33/actor.pt --max-decisions 10 --workers 2 --set graph.features=extended"
$PY --layouts 2000 2001 --starts 9 --out /work/runs/test33/office
$PY --scene building --layouts 2000 2001 2002 2003 2004 --starts 4 --out /work/runs/test33/building
