#!/usr/bin/env bash
# plan.md steps 3-4: the candidate actor (probe.py's pick, CANDIDATE=path) on the validation buildings 1010-1039
# (SET=val) or the held-out buildings 2020-2119 (SET=test), one trial each, in two streams (even and odd seeds,
# one in-process worker each), resumable: /work/runs/$NAME_$SET/building_SEED (NAME=sd). Paired in study.sh with
# EM's and the shipped actor's trials of the same config (revisit_bias/runs/val_pair, zero_shot_buildings_100/runs).
# EXTRA: more overrides (revisit_bias/sweep.sh: EXTRA=policy.revisit_bias=B NAME=rb_sweep_B).
set -e
CANDIDATE=${CANDIDATE:?give CANDIDATE=path/to/actor.pt}
SET=${SET:-val}
NAME=${NAME:-sd}
case $SET in val) FIRST=1010; LAST=1039;; test) FIRST=2020; LAST=2119;; *) echo "SET=$SET: val or test"; exit 2;; esac
OUT=/work/runs/${NAME}_$SET
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
COMMON="scene=building slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 \
  evaluate.progress_bar=false evaluate.workers=1 evaluate.policies=[learned] policy.checkpoint=$CANDIDATE $EXTRA"
stream() {  # stream START: every other seed from START
  for SEED in $(seq $1 2 $LAST); do
    [ -e $OUT/building_$SEED/trials.jsonl ] && continue  # finished before a restart
    $EVAL $COMMON scene.seed=$SEED out=$OUT/building_$SEED
  done
}
stream $FIRST > ${OUT}_even.log 2>&1 &
stream $((FIRST + 1)) > ${OUT}_odd.log 2>&1
wait
