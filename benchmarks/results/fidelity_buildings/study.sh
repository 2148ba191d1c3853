#!/usr/bin/env bash
# plan.md's second check: the shipped actor and EM on the validation buildings 1010-1039 under slam=model_buildings
# (SLAM=model_buildings OUT=/work/runs/modelb_val bash benchmarks/results/keyframes_45deg/run.sh), kept in
# runs/val_model_buildings, against the same buildings under slam=icp (keyframes_45deg/runs/val_15deg) and under
# the default slam=model (frontend_shift/runs/val_model); study_zero_shot.py, closed loop (the paths differ):
#   POLICY_model_buildings_vs_icp.log   each policy under the preset against itself under icp
#   POLICY_model_vs_icp.log             the same for the default model
#   study_val_model_buildings.log       the actor against EM under the preset (compare: icp 1.23, default model 1.06)
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
ICP=$RESULTS/keyframes_45deg/runs/val_15deg
MODEL=$RESULTS/frontend_shift/runs/val_model
V=$HERE/runs/val_model_buildings
keep /work/runs/modelb_val $V
$PY $RESULTS/../study_zero_shot.py $V --pool val_model_buildings --out $HERE/targets_val_model_buildings > $HERE/study_val_model_buildings.log
self_vs $HERE $V $ICP model_buildings_vs_icp
self_vs $HERE $MODEL $ICP model_vs_icp
