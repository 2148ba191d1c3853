#!/usr/bin/env bash
# plan.md: the default again on the same 20 validation scenes with another trial seed (seed=1), the same config
# as run.sh otherwise: with run_em_seed1.sh, two trials per scene for the default and EM.
set -e
cd /work/train_code34
export PYTHONPATH=/work/train_code34
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
SEEDS=scene.seed=1000,1001,1002,1003,1004,1005,1006,1007,1008,1009
COMMON="slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 evaluate.progress_bar=false seed=1"
SPARSE="scene.building.lot_probability=1 scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
$EVAL -m scene=building $SEEDS $COMMON "evaluate.policies=[learned]" policy.checkpoint=/work/main/policies/buildings_sparse_distill/actor.pt out=/work/runs/val_whole/buildings_default_seed1
$EVAL -m scene=building $SEEDS $COMMON $SPARSE "evaluate.policies=[learned]" policy.checkpoint=/work/main/policies/buildings_sparse_distill/actor.pt out=/work/runs/val_whole/sparse_default_seed1
