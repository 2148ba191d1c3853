#!/usr/bin/env bash
# plan.md selection: STEP=preset (step 1) or STEP=icp (step 2): the candidate alone on the validation buildings
# 1010-1039 (keyframes_45deg/run.sh's config, two streams, resumable), then study.sh's figures for that step.
# TAG: a suffix naming the candidate (the 50-min one: ACTOR=/work/runs/tmb_50min_last.pt TAG=_50min).
# FIRST/LAST and REF: other validation buildings and their reference trials (plan.md's last addendum).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
STEP=${STEP:-preset}
case $STEP in preset|icp) ;; *) echo "STEP=$STEP: give STEP=preset or STEP=icp" >&2; exit 2;; esac
ACTOR=${ACTOR:-/work/runs/tmb/checkpoints/last.pt}
SLAM=model_buildings; [ $STEP = icp ] && SLAM=icp
SLAM=$SLAM OUT=/work/runs/tmb_val_$STEP$TAG POLICIES="[learned]" EXTRA="policy.checkpoint=$ACTOR" \
  bash $HERE/../keyframes_45deg/run.sh
STEP=$STEP TAG=$TAG bash $HERE/study.sh
