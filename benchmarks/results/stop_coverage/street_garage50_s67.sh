#!/usr/bin/env bash
# plan.md, session 67 step 2: EM and the shipped default in the street and the garage for seeds 8-49 (street_garage.sh's
# config: slam=icp, until 85 % explored or 600 m), in chunks of seeds (written before explore-rl-eval resumed its
# trials: a cut kept every finished chunk): /work/runs/stop85_street_garage50/seeds_FIRST/{0_street,1_garage}; a chunk
# with both scenes' trials.jsonl is skipped on a restart. Seeds 8-9 repeat stored trials (checked by
# decide_time/compare_s59.py: same_trials_street_garage50_s67.log); SETS=street_garage50 study.sh pools seeds 0-49.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-/work/runs/stop85_street_garage50}
mkdir -p $OUT
for FIRST in 8 16 24 32 40; do
  TRIALS=8; [ $FIRST = 40 ] && TRIALS=10  # seeds 40-49
  DIR=$OUT/seeds_$FIRST
  [ -e $DIR/0_street/trials.jsonl ] && [ -e $DIR/1_garage/trials.jsonl ] && continue
  echo "seeds $FIRST-$((FIRST + TRIALS - 1)) start $(date +%H:%M:%S)"
  SEED=$FIRST TRIALS=$TRIALS OUT=$DIR bash $HERE/street_garage.sh > $DIR.log 2>&1 || { echo "seeds $FIRST: failed, see $DIR.log"; exit 1; }
  echo "seeds $FIRST end $(date +%H:%M:%S)"
done
