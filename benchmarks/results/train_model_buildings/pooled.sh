#!/usr/bin/env bash
# plan.md's last addendum (descriptive): the 95-min candidate under icp on the 90 validation buildings 1010-1099
# pooled, against EM and against the shipped actor (study_zero_shot.py with two report and two reference folders).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
C="$HERE/runs/val_icp_95min $HERE/runs/val_icp_95min_more"
R="$RESULTS/keyframes_45deg/runs/val_15deg $RESULTS/frontend_shift/runs/val_icp_more"
vs_em_and_actor $HERE val_icp_95min_90 "$C" "$R"
