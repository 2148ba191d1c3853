#!/usr/bin/env bash
# plan.md: EM and the shipped default on the validation buildings 1010-1039, slam=icp, until 85 % explored (or 600 m),
# graph.max_nodes=4096; keyframes_45deg/run.sh's two streams, resumable: /work/runs/stop85_val/building_SEED.
# FIRST/LAST/OUT: other seeds or folder; POLICIES=[learned] EXTRA="policy.loop_bias=B": the learned policy alone with
# more overrides (plan.md's addendum: the loop prior at 85 %).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
SLAM=icp BUDGET=600 MAX_NODES=4096 POLICIES=${POLICIES:-[learned,em]} OUT=${OUT:-/work/runs/stop85_val} \
  FIRST=${FIRST:-1010} LAST=${LAST:-1039} bash $HERE/../keyframes_45deg/run.sh
