#!/usr/bin/env bash
# plan.md addendum (exploratory): the shipped actor with revisit_bias=0.5 on validation buildings 1010-1039,
# the config of val.sh. Runs in /work/runs/rb_val/dose/building_SEED.
set -e
BIAS=${BIAS:-0.5}
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
COMMON="scene=building slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 \
  evaluate.progress_bar=false evaluate.workers=1"
for SEED in $(seq 1010 1039); do
  $EVAL $COMMON scene.seed=$SEED evaluate.policies=[learned] policy.revisit_bias=$BIAS \
    out=/work/runs/rb_val/dose/building_$SEED
done
