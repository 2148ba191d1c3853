#!/usr/bin/env bash
# After the selection: the held-out test (once) and the zero-shot studies of the selected actor
# (usage: test_and_zero_shot.sh ACTOR); code frozen at the session-32 start commit, baselines of the
# held-out test from the caches of session 28 (same episodes, same config).
set -e
ACTOR=$1
cd /work/train_code32
export PYTHONPATH=/work/train_code32
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --policy $ACTOR --max-decisions 10 --set graph.features=extended --workers 2"
for kind in office building; do
  mkdir -p /work/runs/test32/$kind && cp /work/runs/test/$kind/episodes.jsonl /work/runs/test32/$kind/
done
$PY --layouts 2000 2001 --starts 9 --out /work/runs/test32/office
$PY --scene building --layouts 2000 2001 2002 2003 2004 --starts 4 --out /work/runs/test32/building
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
$EVAL -m scene=street,garage graph.max_nodes=1024 evaluate.trials=10 evaluate.progress_bar=false \
  policy.checkpoint=$ACTOR out=/work/runs/zero_shot_v4_10
$EVAL -m scene=building scene.seed=2000,2001,2002,2003,2004,2005,2006,2007,2008,2009 slam=icp \
  graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 evaluate.progress_bar=false \
  policy.checkpoint=$ACTOR out=/work/runs/zero_shot_buildings_v4
