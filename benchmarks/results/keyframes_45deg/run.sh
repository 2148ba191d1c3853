#!/usr/bin/env bash
# plan.md step 4: EM and the shipped actor with slam=icp_45deg on the validation buildings 1010-1039 (one trial
# each, revisit_bias/val.sh's config otherwise), in two streams (even and odd seeds), resumable:
# /work/runs/kf45_val/building_SEED; each building's start and end time in the stream's log.
# SLAM=icp OUT=/work/runs/kf15_val: the same at 15 deg on this machine (addendum: wall time per building).
# POLICIES=[em] EXTRA="key=value ...": other policies, more overrides (addendum: loop-closure budgets).
# FIRST=1040 LAST=1099: other building seeds (frontend_shift/plan.md's addendum).
# BUDGET=m MAX_NODES=n: another travel budget and graph.max_nodes (stop_coverage/plan.md).
set -e
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1  # two streams on two cores: one thread each
SLAM=${SLAM:-icp_45deg}
OUT=${OUT:-/work/runs/kf45_val}
POLICIES=${POLICIES:-[learned,em]}
FIRST=${FIRST:-1010}
LAST=${LAST:-1039}
BUDGET=${BUDGET:-250}
MAX_NODES=${MAX_NODES:-1024}
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
COMMON="scene=building slam=$SLAM graph.max_nodes=$MAX_NODES evaluate.trials=1 explore.travel_budget=$BUDGET \
  evaluate.progress_bar=false evaluate.workers=1 evaluate.policies=$POLICIES $EXTRA"
mkdir -p $OUT
stream() {  # stream START: every other seed from START
  for SEED in $(seq $1 2 $LAST); do
    [ -e $OUT/building_$SEED/trials.jsonl ] && continue  # finished before a restart
    echo "building $SEED start $(date +%s)"
    $EVAL $COMMON scene.seed=$SEED out=$OUT/building_$SEED
    echo "building $SEED end $(date +%s)"
  done
}
stream $FIRST > ${OUT}_even.log 2>&1 &
stream $((FIRST + 1)) > ${OUT}_odd.log 2>&1
wait
