#!/usr/bin/env bash
# plan.md (session 36; order of session 38): the scratch candidate's zero-shot trials (street and garage 20, 20
# held-out buildings) against EM's seeded trials of zero_shot_v5_20 (issue 24's travel and map-error targets for
# the 2-hour pipeline) and against the shipped policy; its whole explorations on the 20 validation scenes with two
# trials per scene, pooled against EM's (the rule of session 34) and against the shipped policy's; last its
# 10-decision validation on the four sets (for comparing it with the other candidates there).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/steps.sh
ACTOR=$SCRATCH_ACTOR
date; uptime
zero_shot_trials $ACTOR /work/runs/zs36
zero_shot_study /work/runs/zs36 scratch
date; uptime
whole_two_trials $ACTOR scratch
keep_whole scratch
pool_whole scratch em_choice_long shipped
date; uptime
validate_10 $ACTOR scratch_s38
date; uptime
echo "== done"
