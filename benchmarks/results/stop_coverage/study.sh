#!/usr/bin/env bash
# plan.md: keep run.sh's finished buildings in runs/val, then study_zero_shot.py (the learned trials against EM's of
# the same run, paired by building):
#   study_val.log / targets_val                  every finished building, compared at the common coverage
#   reached_val.log                              how many buildings each policy brought to 85 %
#   study_val_reached.log / targets_val_reached  only the buildings both policies brought to 85 %
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
STUDY="$PY $RESULTS/../study_zero_shot.py"
keep ${RUN:-/work/runs/stop85_val} $HERE/runs/val
$STUDY $HERE/runs/val --pool val --out $HERE/targets_val > $HERE/study_val.log
rm -rf $HERE/runs/val_reached
$PY $HERE/reached.py $HERE/runs/val --out $HERE/runs/val_reached > $HERE/reached_val.log
[ -d $HERE/runs/val_reached ] || exit 0
$STUDY $HERE/runs/val_reached --pool val_reached --out $HERE/targets_val_reached > $HERE/study_val_reached.log
