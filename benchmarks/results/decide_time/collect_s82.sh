#!/usr/bin/env bash
# Session 82: bench_collect (4 paired rounds each) of session 81's code (e37fb363) and today's (the learner's
# value targets without the duplicate critic calls; today's with the machine's ceiling, --ceiling), one after the
# other, nothing else running (issue 22 item 5). ROUND names the logs; round 1 runs today's code first, round 2
# session 81's first.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
cd $HERE/../../..
source $HERE/code_versions_s82.sh
R=${ROUND:-1}
if [ $R = 1 ]; then order="NOW BEFORE"; else order="BEFORE NOW"; fi
for side in $order; do
  if [ $side = NOW ]; then measure bench_collect_rounds4_s82_r$R.log $NOW bench_collect --ceiling
  else measure bench_collect_rounds4_before_s82_r$R.log $BEFORE bench_collect; fi
done
