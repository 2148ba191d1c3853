#!/usr/bin/env bash
# Session 76 (plan.md, step 2; policy-independent groundwork): EM's trials in the garage and the street for seeds
# 50-199 (street_garage.sh's config: slam=icp, until 85 % explored or 600 m), beside the 50 per scene of
# runs/street_garage50 (seeds 0-49), so the named scenes reach 200 trials per scene. Chunks of 25 seeds alternate
# garage and street (a cut leaves both scenes with about as many): /work/runs/stop85_named200_em/SCENE_seeds_FIRST/
# 0_SCENE; a finished chunk (its trials.jsonl) is skipped on a restart and an unfinished one resumes trial by trial
# (explore-rl-eval's partial log). OUT: another folder.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-/work/runs/stop85_named200_em}
mkdir -p $OUT
for FIRST in 50 75 100 125 150 175; do
  for SCENE in garage street; do
    DIR=$OUT/${SCENE}_seeds_$FIRST
    [ -e $DIR/0_$SCENE/trials.jsonl ] && continue
    echo "$SCENE seeds $FIRST-$((FIRST + 24)) start $(date -u +%H:%M:%S)"
    SCENES=$SCENE SEED=$FIRST TRIALS=25 POLICIES=[em] OUT=$DIR bash $HERE/street_garage.sh >> $DIR.log 2>&1 \
      || { echo "$SCENE seeds $FIRST: failed, see $DIR.log"; exit 1; }
    echo "$SCENE seeds $FIRST end $(date -u +%H:%M:%S)"
  done
done
