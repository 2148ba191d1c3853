#!/usr/bin/env bash
# Session 77 (plan.md's addendum of 15:19 UTC; measures the shipped default, selects nothing): the shipped default's
# learned trials in the street and the garage for seeds 50-119 (street_garage.sh's config) into
# /work/runs/stop85_default_named_s77, then joined with its stored seeds 0-49 of runs/street_garage50 (session 67) into
# /work/runs/stop85_street_garage_default120/{0_street,1_garage}/trials.jsonl, 120 per scene, which study.sh's set
# street_garage200_default120 reads against EM's 200.
#   run   the new trials (resumable: explore-rl-eval's partial log)
#   join  the 120 per scene, once both scenes' new trials are finished
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
NEW=${NEW:-/work/runs/stop85_default_named_s77}
JOINED=/work/runs/stop85_street_garage_default120
stage_run() {
  SEED=50 TRIALS=70 POLICIES=[learned] OUT=$NEW bash $HERE/street_garage.sh
}
stage_join() {
  for name in 0_street 1_garage; do
    [ -e $NEW/$name/trials.jsonl ] || { echo "$NEW/$name/trials.jsonl: not finished; run the stage run first" >&2; exit 2; }
    mkdir -p $JOINED/$name
    { grep '"policy": "learned"' $HERE/runs/street_garage50/$name/trials.jsonl; cat $NEW/$name/trials.jsonl; } \
      > $JOINED/$name/trials.jsonl
  done
}
run_stages "run join" "$@"
