#!/usr/bin/env bash
# plan.md: keep the candidate's validation trials (runs/val_STEP) and pair them by building with EM's and the
# shipped actor's trials under the same front end (study_zero_shot.py):
#   study_val_STEP.log    candidate against EM      (the rule's ratios)
#   direct_val_STEP.log   candidate against the shipped actor
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
STEP=${STEP:-preset}
REF=$RESULTS/fidelity_buildings/runs/val_model_buildings
[ $STEP = icp ] && REF=$RESULTS/keyframes_45deg/runs/val_15deg
V=$HERE/runs/val_$STEP
keep /work/runs/tmb_val_$STEP $V
$PY $RESULTS/../study_zero_shot.py $V --reference $REF --pool val_$STEP --out $HERE/targets_val_$STEP \
  > $HERE/study_val_$STEP.log
$PY $RESULTS/../study_zero_shot.py $V --reference $REF --reference-policy learned --pool val_${STEP}_direct \
  --out $HERE/targets_val_${STEP}_direct > $HERE/direct_val_$STEP.log
