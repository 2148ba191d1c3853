#!/usr/bin/env bash
# plan.md step 1: validation buildings 1010-1039, one at a time: EM and the shipped actor, then the actor with the
# calibrated revisit prior (calibrate.log). Runs in /work/runs/rb_val/{pair,biased}/building_SEED.
# DOSE=1 (dose.sh): only the actor with the prior, into /work/runs/rb_val/dose/building_SEED.
set -e
BIAS=${BIAS:-0.1}
KIND=${DOSE:+dose}
KIND=${KIND:-biased}
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
COMMON="scene=building slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 \
  evaluate.progress_bar=false evaluate.workers=1"
for SEED in $(seq 1010 1039); do
  [ -n "$DOSE" ] || $EVAL $COMMON scene.seed=$SEED evaluate.policies=[learned,em] out=/work/runs/rb_val/pair/building_$SEED
  $EVAL $COMMON scene.seed=$SEED evaluate.policies=[learned] policy.revisit_bias=$BIAS \
    out=/work/runs/rb_val/$KIND/building_$SEED
done
