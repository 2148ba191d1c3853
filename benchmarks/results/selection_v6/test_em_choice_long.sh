#!/usr/bin/env bash
# plan.md: the held-out test of the em_choice_long candidate (session 35), once (test33's cached episodes, frozen session-32
# code, as selection_v5/test.sh), then its zero-shot (learned only; EM's seeded trials of zero_shot_v5_20 are
# reproduced on this code and paired by --reference). Only run if it passed the rule.
set -e
ACTOR=/work/runs/em_choice_long/checkpoints/last.pt
cd /work/train_code32
export PYTHONPATH=/work/train_code32
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --policy $ACTOR --max-decisions 10 --workers 2 --set graph.features=extended"
for kind in office building; do mkdir -p /work/runs/test35/$kind && cp /work/runs/test33/$kind/episodes.jsonl /work/runs/test35/$kind/; done
$PY --layouts 2000 2001 --starts 9 --out /work/runs/test35/office
$PY --scene building --layouts 2000 2001 2002 2003 2004 --starts 4 --out /work/runs/test35/building
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
COMMON="graph.max_nodes=1024 evaluate.progress_bar=false evaluate.policies=[learned] policy.checkpoint=$ACTOR"
$EVAL -m scene=street,garage evaluate.trials=10 $COMMON out=/work/runs/zs35/street_garage_a
$EVAL -m scene=street,garage seed=10 scene.seed=0 evaluate.trials=10 $COMMON out=/work/runs/zs35/street_garage_b
$EVAL -m scene=building scene.seed=2000,2001,2002,2003,2004,2005,2006,2007,2008,2009,2010,2011,2012,2013,2014,2015,2016,2017,2018,2019 \
  slam=icp evaluate.trials=1 explore.travel_budget=250 $COMMON out=/work/runs/zs35/buildings
