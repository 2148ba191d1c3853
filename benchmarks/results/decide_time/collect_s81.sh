#!/usr/bin/env bash
# Session 81: bench_collect (4 paired rounds each) of session 80's code (946dedb3) and today's, one after the other,
# nothing else running: does the cheaper env step change the two-worker scaling (issue 22 item 5)? ROUND names the
# logs (round 1: today's code first, round 2: session 80's first).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
cd $HERE/../../..
source $HERE/code_versions_s81.sh
R=${ROUND:-2}
if [ $R = 1 ]; then order="NOW BEFORE"; else order="BEFORE NOW"; fi
for side in $order; do
  if [ $side = NOW ]; then measure bench_collect_rounds4_s81_r$R.log $NOW bench_collect
  else measure bench_collect_rounds4_before_s81_r$R.log $BEFORE bench_collect; fi
done
