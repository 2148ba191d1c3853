#!/usr/bin/env bash
# plan.md: the candidate's loop-prior trials (run.sh) kept in runs/, paired by building (study_zero_shot.py):
#   study_val_B.log / direct_val_B.log    validation, against EM / the shipped actor (keyframes_45deg/runs/val_15deg)
#   self_val_B.log                        validation, against the candidate alone (session 49's icp trials)
#   prior_val_B.log                       validation, against the shipped actor with the same prior (session 46's
#                                         loop_bias/runs/val_B, where it ran)
#   study_test_B.log / direct_test_B.log  held out, against EM / the shipped actor (zero_shot_buildings_100/runs)
# the descriptive addendum, 90 validation buildings 1010-1099 (run.sh SET=more for 1040-1099):
#   study_val90_B.log / direct_val90_B.log                  the candidate with B, against EM / the shipped actor
#   study_shipped_val90_B.log / direct_shipped_val90_B.log  the shipped actor with B, against EM / itself alone
#   prior_val90_B.log                                       the candidate with B against the shipped actor with B
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
STUDY="$PY $RESULTS/../study_zero_shot.py"
for run in /work/runs/clb_*_val; do
  [ -d $run ] || continue
  bias=${run#/work/runs/clb_}; bias=${bias%_val}
  keep $run $HERE/runs/val_$bias
  [ -d $HERE/runs/val_$bias ] || continue  # no building finished yet
  vs_em_and_actor $HERE val_$bias $HERE/runs/val_$bias $RESULTS/keyframes_45deg/runs/val_15deg
  $STUDY $HERE/runs/val_$bias --reference $RESULTS/train_model_buildings/runs/val_icp_95min \
    --reference-policy learned --pool val_${bias}_self --out $HERE/targets_val_${bias}_self > $HERE/self_val_$bias.log
  PRIOR=$RESULTS/loop_bias/runs/val_$bias
  [ -d $PRIOR ] && $STUDY $HERE/runs/val_$bias --reference $PRIOR --reference-policy learned \
    --pool val_${bias}_prior --out $HERE/targets_val_${bias}_prior > $HERE/prior_val_$bias.log
done
REFS90="$RESULTS/keyframes_45deg/runs/val_15deg $RESULTS/frontend_shift/runs/val_icp_more"
for run in /work/runs/clb_*_more; do
  [ -d $run ] || continue
  bias=${run#/work/runs/clb_}; bias=${bias%_more}
  keep $run $HERE/runs/more_$bias
  [ -d $HERE/runs/more_$bias ] || continue
  CANDIDATE90="$HERE/runs/val_$bias $HERE/runs/more_$bias"
  vs_em_and_actor $HERE val90_$bias "$CANDIDATE90" "$REFS90"
  [ -d /work/runs/slb_${bias}_more ] || continue
  keep /work/runs/slb_${bias}_more $HERE/runs/shipped_more_$bias
  SHIPPED90="$RESULTS/loop_bias/runs/val_$bias $HERE/runs/shipped_more_$bias"
  vs_em_and_actor $HERE shipped_val90_$bias "$SHIPPED90" "$REFS90"
  $STUDY $CANDIDATE90 --reference $SHIPPED90 --reference-policy learned --pool val90_${bias}_prior \
    --out $HERE/targets_val90_${bias}_prior > $HERE/prior_val90_$bias.log
done
ZS=$RESULTS/zero_shot_buildings_100/runs
for run in /work/runs/clb_*_test; do
  [ -d $run ] || continue
  bias=${run#/work/runs/clb_}; bias=${bias%_test}
  for s in even odd; do keep $run $HERE/runs/test_$bias/$s $s; done
  vs_em_and_actor $HERE test_$bias "$HERE/runs/test_$bias/even $HERE/runs/test_$bias/odd" "$ZS/even $ZS/odd"
done
