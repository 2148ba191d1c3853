#!/usr/bin/env bash
# plan.md: keep run.sh's trials (SET=val; the control arm and SET=test where they ran) in runs/, then the figures (study_zero_shot.py, pooled
# over every building finished): against EM, and against the shipped actor alone (--reference-policy learned).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
PY=${PY:-/work/main/.venv/bin/python}
STUDY=$HERE/../../study_zero_shot.py
PAIR=$HERE/../revisit_bias/runs/val_pair  # EM's and the shipped actor's validation trials (same config)
ZS=$HERE/../zero_shot_buildings_100/runs  # EM's and the shipped actor's held-out trials
source $HERE/../keep.sh  # keep SRC DST: each finished building's trials and summary
# the stakes actor (runs/val) and, where it ran, the em_choice control arm (runs/val_control)
for name in val val_control; do
  run=/work/runs/sd_val; [ $name = val_control ] && run=/work/runs/sd_control_val
  [ -d $run ] || continue
  keep $run $HERE/runs/$name
  $PY $STUDY $HERE/runs/$name --reference $PAIR --pool $name --out $HERE/targets_$name > $HERE/study_$name.log
  $PY $STUDY $HERE/runs/$name --reference $PAIR --reference-policy learned --pool ${name}_direct \
    --out $HERE/targets_${name}_direct > $HERE/direct_$name.log
done
if [ -d /work/runs/sd_test ]; then
  keep /work/runs/sd_test $HERE/runs/test
  $PY $STUDY $HERE/runs/test --reference $ZS/even $ZS/odd --pool test --out $HERE/targets_test > $HERE/study_test.log
  $PY $STUDY $HERE/runs/test --reference $ZS/even $ZS/odd --reference-policy learned --pool test_direct \
    --out $HERE/targets_test_direct > $HERE/direct_test.log
fi
if [ -d $HERE/runs/val_control ]; then  # the stakes actor directly against the em_choice control arm
  $PY $STUDY $HERE/runs/val --reference $HERE/runs/val_control --reference-policy learned --pool val_vs_control \
    --out $HERE/targets_val_vs_control > $HERE/direct_val_vs_control.log
fi
