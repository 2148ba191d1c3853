#!/usr/bin/env bash
# plan.md: keep the slam=model run's finished buildings in runs/val_model, then
#   study_val_model.log   the shipped actor against EM under slam=model (study_zero_shot.py)
#   shift.log             per building, (actor/EM under model) over (actor/EM under icp), paired; the icp side is
#                         session 47's 15 deg re-run of the same buildings (keyframes_45deg/targets_val_15deg)
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
V=$HERE/runs/val_model
keep /work/runs/model_val $V
$PY $RESULTS/../study_zero_shot.py $V --pool val_model --out $HERE/targets_val_model > $HERE/study_val_model.log
$PY $HERE/shift.py $RESULTS/keyframes_45deg/targets_val_15deg/val_15deg/targets.json \
  $HERE/targets_val_model/val_model/targets.json > $HERE/shift.log
# addendum: the 60 buildings 1040-1099 under both front ends (run_more.sh), kept in runs/val_{model,icp}_more;
#   shift_60.log   the paired figure on the 60 new buildings alone (replication)
#   shift_90.log   the figure of record, all 90 buildings 1010-1099 (study_val_{model,icp}_90.log: each front end)
VM=$HERE/runs/val_model_more
VI=$HERE/runs/val_icp_more
keep /work/runs/model_val_more $VM
keep /work/runs/icp_val_more $VI
[ -d $VM ] && [ -d $VI ] || exit 0
ICP30=$RESULTS/keyframes_45deg/runs/val_15deg
for set in 60 90; do
  if [ $set = 60 ]; then model="$VM"; icp="$VI"; else model="$V $VM"; icp="$ICP30 $VI"; fi
  $PY $RESULTS/../study_zero_shot.py $model --pool val_model_$set --out $HERE/targets_val_model_$set \
    > $HERE/study_val_model_$set.log
  $PY $RESULTS/../study_zero_shot.py $icp --pool val_icp_$set --out $HERE/targets_val_icp_$set \
    > $HERE/study_val_icp_$set.log
  $PY $HERE/shift.py $HERE/targets_val_icp_$set/val_icp_$set/targets.json \
    $HERE/targets_val_model_$set/val_model_$set/targets.json > $HERE/shift_$set.log
done
# exploratory decomposition (after reading shift_30): each policy under the model against itself under icp, 90 buildings
#   {em,learned}_model_vs_icp_90.log
self_vs $HERE "$V $VM" "$ICP30 $VI" model_vs_icp_90  # folders of several reports: one string each
