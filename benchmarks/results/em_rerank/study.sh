#!/usr/bin/env bash
# plan.md step 2 (a diagnostic after the addendum): keep run.sh's k = 2 validation trials in runs/val_top2, then
# study_zero_shot.py against EM's and the shipped actor's trials of the same config (revisit_bias/runs/val_pair).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
PY=${PY:-/work/main/.venv/bin/python}
STUDY=$HERE/../../study_zero_shot.py
PAIR=$HERE/../revisit_bias/runs/val_pair
source $HERE/../keep.sh
keep /work/runs/em_top_2_val $HERE/runs/val_top2
$PY $STUDY $HERE/runs/val_top2 --reference $PAIR --pool val_top2 --out $HERE/targets_val_top2 > $HERE/study_val_top2.log
$PY $STUDY $HERE/runs/val_top2 --reference $PAIR --reference-policy learned --pool val_top2_direct \
  --out $HERE/targets_val_top2_direct > $HERE/direct_val_top2.log
