#!/usr/bin/env bash
# After the selection (selection_rule.md): the held-out test (once) and the zero-shot studies of the
# selected sparse-lot candidate, on the same episodes and config as sessions 28 and 32 (baselines of the
# held-out tests from their caches; the zero-shot runs replay every policy, EM's trials must reproduce).
# Then held-out parking lots (cache of session 32) and held-out sparse lots (new: EM, random, nearest,
# candidate, then the default on the same episodes). Code frozen at the session-32 start commit.
# usage: test_and_zero_shot.sh ACTOR
set -e
ACTOR=$1
DEFAULT=/work/main/policies/buildings_lots_distill/actor.pt
cd /work/train_code32
export PYTHONPATH=/work/train_code32
OUT=/work/runs/test33
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --max-decisions 10 --workers 2"
FEAT="graph.features=extended"
for kind in office building lots; do mkdir -p $OUT/$kind; done
cp /work/runs/test32/office/episodes.jsonl $OUT/office/
cp /work/runs/test32/building/episodes.jsonl $OUT/building/
cp /work/runs/test32/lots_old/episodes.jsonl $OUT/lots/
$PY --policy $ACTOR --layouts 2000 2001 --starts 9 --set $FEAT --out $OUT/office
$PY --policy $ACTOR --scene building --layouts 2000 2001 2002 2003 2004 --starts 4 --set $FEAT --out $OUT/building
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
$EVAL -m scene=street,garage graph.max_nodes=1024 evaluate.trials=10 evaluate.progress_bar=false \
  policy.checkpoint=$ACTOR out=/work/runs/zero_shot_v5_10
$EVAL -m scene=building scene.seed=2000,2001,2002,2003,2004,2005,2006,2007,2008,2009 slam=icp \
  graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 evaluate.progress_bar=false \
  policy.checkpoint=$ACTOR out=/work/runs/zero_shot_buildings_v5
$PY --policy $ACTOR --scene building --layouts 2000 2001 2002 2003 2004 --starts 4 \
  --set $FEAT scene.building.lot_probability=1 --out $OUT/lots
SPARSE="--scene building --layouts 2000 2001 2002 2003 2004 --starts 4 --set $FEAT scene.building.lot_probability=1 \
  scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] \
  scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
mkdir -p $OUT/sparse_candidate $OUT/sparse_default
$PY --policy $ACTOR $SPARSE --out $OUT/sparse_candidate
cp $OUT/sparse_candidate/episodes.jsonl $OUT/sparse_default/
$PY --policy $DEFAULT $SPARSE --out $OUT/sparse_default
