#!/usr/bin/env bash
# plan.md: the session-49 candidate with loop_bias=B (BIAS, one value per call), learned policy only, slam=icp, on
# the validation buildings 1010-1039 (SET=val), the further validation buildings 1040-1099 (SET=more, the
# descriptive addendum) or the held-out buildings 2020-2119 (SET=test); keyframes_45deg/run.sh's config and two
# streams, resumable: /work/runs/NAME_B_SET/building_SEED.
# ACTOR=path NAME=slb: another actor (the addendum: the shipped actor with the same prior).
set -e
BIAS=${BIAS:?give BIAS=value}
SET=${SET:-val}
HERE=$(cd "$(dirname "$0")" && pwd)
case $SET in val) FIRST=1010; LAST=1039;; more) FIRST=1040; LAST=1099;; test) FIRST=2020; LAST=2119;;
  *) echo "SET=$SET: give val, more or test" >&2; exit 2;; esac
ACTOR=${ACTOR:-$HERE/../../../policies/buildings_model_em_choice/actor.pt}
NAME=${NAME:-clb}
SLAM=icp OUT=/work/runs/${NAME}_${BIAS}_$SET POLICIES="[learned]" FIRST=$FIRST LAST=$LAST \
  EXTRA="policy.checkpoint=$ACTOR policy.loop_bias=$BIAS" bash $HERE/../keyframes_45deg/run.sh
