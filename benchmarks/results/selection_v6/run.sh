#!/usr/bin/env bash
# plan.md: whole explorations on 10 validation buildings and 10 validation sparse lots, EM and each candidate
# in its own explore-rl-eval run (EM in parallel with the learned runs); code frozen at 21e9525.
# usage: run.sh em | run.sh learned NAME ACTOR
set -e
cd /work/train_code34
export PYTHONPATH=/work/train_code34
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
SEEDS=scene.seed=1000,1001,1002,1003,1004,1005,1006,1007,1008,1009
COMMON="slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 evaluate.progress_bar=false"
SPARSE="scene.building.lot_probability=1 scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
if [ "$1" = em ]; then
  POLICY="evaluate.policies=[em]"; NAME=em; ACTOR_ARG=""
else
  POLICY="evaluate.policies=[learned]"; NAME=$2; ACTOR_ARG="policy.checkpoint=$3"
fi
$EVAL -m scene=building $SEEDS $COMMON "$POLICY" $ACTOR_ARG out=/work/runs/val_whole/buildings_$NAME
$EVAL -m scene=building $SEEDS $COMMON $SPARSE "$POLICY" $ACTOR_ARG out=/work/runs/val_whole/sparse_$NAME
