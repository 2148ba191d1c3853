#!/usr/bin/env bash
# plan.md step 4: keep run.sh's finished buildings in runs/val_45deg, then study_zero_shot.py (pooled over the
# finished buildings):
#   study_val_45deg.log      the shipped actor against EM, both at 45 deg (compare: revisit_bias/study_val_shipped.log,
#                            the same at 15 deg)
#   em_45_vs_15.log          EM at 45 deg against EM at 15 deg (revisit_bias/runs/val_pair)
#   learned_45_vs_15.log     the shipped actor at 45 deg against itself at 15 deg
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
STUDY=$RESULTS/../study_zero_shot.py
PAIR=$RESULTS/revisit_bias/runs/val_pair
V=$HERE/runs/val_45deg
keep /work/runs/kf45_val $V
$PY $STUDY $V --pool val_45deg --out $HERE/targets_val_45deg > $HERE/study_val_45deg.log
$PY $STUDY $V --policy em --reference $PAIR --reference-policy em --pool em_45_vs_15 \
  --out $HERE/targets_em_45_vs_15 > $HERE/em_45_vs_15.log
$PY $STUDY $V --policy learned --reference $PAIR --reference-policy learned --pool learned_45_vs_15 \
  --out $HERE/targets_learned_45_vs_15 > $HERE/learned_45_vs_15.log
