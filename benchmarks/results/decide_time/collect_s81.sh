#!/usr/bin/env bash
# Session 81: bench_collect (4 paired rounds each) of session 80's code (946dedb3) and today's, one after the other,
# nothing else running: does the cheaper env step change the two-worker scaling (issue 22 item 5)? ROUND names the
# logs (round 1: today's code first, round 2: session 80's first). Later sessions reuse it (collect_s82.sh):
# SESSION names the logs, VERSIONS the script that checks out the earlier code, NOW_ARGS go to today's run.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
cd $HERE/../../..
S=${SESSION:-81}
source $HERE/${VERSIONS:-code_versions_s81.sh}
R=${ROUND:-2}
if [ $R = 1 ]; then order="NOW BEFORE"; else order="BEFORE NOW"; fi
for side in $order; do
  if [ $side = NOW ]; then measure bench_collect_rounds4_s${S}_r$R.log $NOW bench_collect $NOW_ARGS
  else measure bench_collect_rounds4_before_s${S}_r$R.log $BEFORE bench_collect; fi
done
