#!/usr/bin/env bash
# plan.md: export the run's last actor, keep its validation trials (../stakes_distill/run.sh, NAME=a2c_me) in
# runs/val, then study_zero_shot.py against EM's and the shipped actor's trials (revisit_bias/runs/val_pair).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
PY=${PY:-/work/main/.venv/bin/python}
STUDY=$HERE/../../study_zero_shot.py
PAIR=$HERE/../revisit_bias/runs/val_pair
source $HERE/../keep.sh
keep /work/runs/a2c_me_val $HERE/runs/val
$PY $STUDY $HERE/runs/val --reference $PAIR --pool val --out $HERE/targets_val > $HERE/study_val.log
$PY $STUDY $HERE/runs/val --reference $PAIR --reference-policy learned --pool val_direct \
  --out $HERE/targets_val_direct > $HERE/direct_val.log
