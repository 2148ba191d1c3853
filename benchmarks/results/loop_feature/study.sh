#!/usr/bin/env bash
# plan.md step 3: the candidate's validation trials (../stakes_distill/run.sh, NAME=lf) kept in runs/val and studied
# against EM's and the shipped actor's trials of the same config (study_val.log, direct_val.log); with TEST=1 also
# the held-out buildings 2020-2119 (NAME=lf SET=test) against EM's and the shipped actor's trials of
# ../zero_shot_buildings_100 (study_test.log, direct_test.log).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
val_study /work/runs/lf_val $HERE val
if [ -n "$TEST" ]; then
  ZS=$RESULTS/zero_shot_buildings_100/runs
  for s in even odd; do keep /work/runs/lf_test $HERE/runs/test/$s $s; done
  $PY $RESULTS/../study_zero_shot.py $HERE/runs/test/even $HERE/runs/test/odd --reference $ZS/even $ZS/odd \
    --pool test --out $HERE/targets_test > $HERE/study_test.log
  $PY $RESULTS/../study_zero_shot.py $HERE/runs/test/even $HERE/runs/test/odd --reference $ZS/even $ZS/odd \
    --reference-policy learned --pool test_direct --out $HERE/targets_test_direct > $HERE/direct_test.log
fi
