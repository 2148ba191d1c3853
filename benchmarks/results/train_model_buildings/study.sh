#!/usr/bin/env bash
# plan.md: keep the candidate's validation trials (runs/val_STEPTAG) and pair them by building with EM's and the
# shipped actor's trials under the same front end (study_zero_shot.py):
#   study_val_STEPTAG.log    candidate against EM      (the rule's ratios)
#   direct_val_STEPTAG.log   candidate against the shipped actor
#   shiftTAG.log             (after both steps) the candidate against the shipped actor, icp over the preset
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
STEP=${STEP:-preset}
case $STEP in preset|icp) ;; *) echo "STEP=$STEP: give STEP=preset or STEP=icp" >&2; exit 2;; esac
N=val_$STEP$TAG  # TAG: val.sh's candidate suffix
DEFAULT_REF=$RESULTS/fidelity_buildings/runs/val_model_buildings
[ $STEP = icp ] && DEFAULT_REF=$RESULTS/keyframes_45deg/runs/val_15deg
REF=${REF:-$DEFAULT_REF}  # other buildings: their EM and shipped-actor trials (plan.md's last addendum)
V=$HERE/runs/$N
keep /work/runs/tmb_$N $V
vs_em_and_actor $HERE $N $V $REF
# with both steps run for a candidate: how its standing against the shipped actor moves from the preset to icp,
# paired by building (frontend_shift/shift.py; below 1: it stands better under icp): shiftTAG.log
A=$HERE/targets_val_preset${TAG}_direct/val_preset${TAG}_direct/targets.json
B=$HERE/targets_val_icp${TAG}_direct/val_icp${TAG}_direct/targets.json
if [ -e $A ] && [ -e $B ]; then $PY $RESULTS/frontend_shift/shift.py $A $B > $HERE/shift$TAG.log; fi
