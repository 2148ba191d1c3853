#!/usr/bin/env bash
# plan.md (session 39): the rest of scratch_next.sh (stopped after its zero-shot part in session 38): the 2-hour
# actor's whole explorations of the 20 validation scenes, two trials per scene, pooled against EM's two trials
# (targets_scratch_2trials) and against the shipped policy's (direct_scratch_vs_shipped).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/steps.sh
ACTOR=$SCRATCH_ACTOR
date; uptime
whole_two_trials $ACTOR scratch
keep_whole scratch
pool_whole scratch em_choice_long shipped
date; uptime
echo "== done"
