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
# addendum: the 15 deg pair re-run on this machine (run.sh with SLAM=icp OUT=/work/runs/kf15_val), kept in
# runs/val_15deg; the same three comparisons against it, and it against the committed 15 deg pair
V15=$HERE/runs/val_15deg
keep /work/runs/kf15_val $V15
[ -d $V15 ] || exit 0
$PY $STUDY $V15 --pool val_15deg --out $HERE/targets_val_15deg > $HERE/study_val_15deg.log
for policy in em learned; do
  $PY $STUDY $V --policy $policy --reference $V15 --reference-policy $policy --pool ${policy}_45_vs_15_here \
    --out $HERE/targets_${policy}_45_vs_15_here > $HERE/${policy}_45_vs_15_here.log
  $PY $STUDY $V15 --policy $policy --reference $PAIR --reference-policy $policy --pool ${policy}_15_rerun \
    --out $HERE/targets_${policy}_15_rerun > $HERE/${policy}_15_rerun.log
done
# addendum (loop-closure budgets): EM at 45 deg with doubled per-keyframe budgets, against EM at 15 and 45 deg
VB=$HERE/runs/val_45deg_budget
keep /work/runs/kf45_budget_val $VB
[ -d $VB ] || exit 0
for ref in 15deg 45deg; do
  $PY $STUDY $VB --policy em --reference $HERE/runs/val_$ref --reference-policy em --pool em_budget_vs_$ref \
    --out $HERE/targets_em_budget_vs_$ref > $HERE/em_budget_vs_$ref.log
done
# addendum (the budgets in the preset): the shipped actor at the new slam=icp_45deg against EM's budget run (the
# same config) and against itself at 15 deg
VL=$HERE/runs/val_45deg_budget_learned
keep /work/runs/kf45_budget_val_learned $VL
[ -d $VL ] || exit 0
$PY $STUDY $VL --reference $VB --pool learned_vs_em_budget --out $HERE/targets_learned_vs_em_budget \
  > $HERE/learned_vs_em_budget.log
$PY $STUDY $VL --policy learned --reference $HERE/runs/val_15deg --reference-policy learned \
  --pool learned_budget_vs_15deg --out $HERE/targets_learned_budget_vs_15deg > $HERE/learned_budget_vs_15deg.log
