#!/usr/bin/env bash
# plan.md: keep the candidate's validation trials (runs/val_STEPTAG) and pair them by building with EM's and the
# shipped actor's trials under the same front end (study_zero_shot.py):
#   study_val_STEPTAG.log    candidate against EM      (the rule's ratios)
#   direct_val_STEPTAG.log   candidate against the shipped actor
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
STEP=${STEP:-preset}
N=val_$STEP$TAG  # TAG: val.sh's candidate suffix
REF=$RESULTS/fidelity_buildings/runs/val_model_buildings
[ $STEP = icp ] && REF=$RESULTS/keyframes_45deg/runs/val_15deg
V=$HERE/runs/$N
keep /work/runs/tmb_$N $V
$PY $RESULTS/../study_zero_shot.py $V --reference $REF --pool $N --out $HERE/targets_$N > $HERE/study_$N.log
$PY $RESULTS/../study_zero_shot.py $V --reference $REF --reference-policy learned --pool ${N}_direct \
  --out $HERE/targets_${N}_direct > $HERE/direct_$N.log
