#!/usr/bin/env bash
# plan.md: the loop prior's trials (run.sh, BIAS=B) kept in runs/val_B and studied against EM's and the shipped
# actor's trials of the same config (study_val_B.log, direct_val_B.log); the held-out buildings 2020-2119
# (SET=test), where they ran, against EM's and the shipped actor's trials of ../zero_shot_buildings_100
# (study_test_B.log, direct_test_B.log).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
ZS=$RESULTS/zero_shot_buildings_100/runs
for run in /work/runs/lb_*_val; do
  bias=${run#/work/runs/lb_}; bias=${bias%_val}
  val_study $run $HERE val_$bias
done
for run in /work/runs/lb_*_test; do
  [ -d $run ] || continue
  bias=${run#/work/runs/lb_}; bias=${bias%_test}
  for s in even odd; do keep $run $HERE/runs/test_$bias/$s $s; done
  $PY $RESULTS/../study_zero_shot.py $HERE/runs/test_$bias/even $HERE/runs/test_$bias/odd --reference $ZS/even \
    $ZS/odd --pool test_$bias --out $HERE/targets_test_$bias > $HERE/study_test_$bias.log
  $PY $RESULTS/../study_zero_shot.py $HERE/runs/test_$bias/even $HERE/runs/test_$bias/odd --reference $ZS/even \
    $ZS/odd --reference-policy learned --pool test_${bias}_direct --out $HERE/targets_test_${bias}_direct \
    > $HERE/direct_test_$bias.log
done
