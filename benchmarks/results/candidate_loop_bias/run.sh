#!/usr/bin/env bash
# plan.md: the session-49 candidate with loop_bias=B (BIAS, one value per call), learned policy only, slam=icp, on
# the validation buildings 1010-1039 (SET=val) or the held-out buildings 2020-2119 (SET=test); keyframes_45deg/run.sh's
# config and two streams, resumable: /work/runs/clb_B_SET/building_SEED.
set -e
BIAS=${BIAS:?give BIAS=value}
SET=${SET:-val}
HERE=$(cd "$(dirname "$0")" && pwd)
case $SET in val) FIRST=1010; LAST=1039;; test) FIRST=2020; LAST=2119;; *) echo "SET=$SET: give val or test" >&2; exit 2;; esac
ACTOR=$HERE/../../../policies/buildings_model_em_choice/actor.pt
SLAM=icp OUT=/work/runs/clb_${BIAS}_$SET POLICIES="[learned]" FIRST=$FIRST LAST=$LAST \
  EXTRA="policy.checkpoint=$ACTOR policy.loop_bias=$BIAS" bash $HERE/../keyframes_45deg/run.sh
