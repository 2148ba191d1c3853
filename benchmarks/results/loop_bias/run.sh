#!/usr/bin/env bash
# plan.md: the shipped actor with loop_bias=B (BIAS, one value per call) on the validation buildings 1010-1039
# (SET=val) or the held-out buildings 2020-2119 (SET=test), revisit_bias/val.sh's config, in two streams:
# /work/runs/lb_B_SET/building_SEED (resumable).
set -e
BIAS=${BIAS:?give BIAS=value}
HERE=$(cd "$(dirname "$0")" && pwd)
CANDIDATE=/work/main/policies/buildings_sparse_em_choice/actor.pt NAME=lb_$BIAS SET=${SET:-val} \
  EXTRA="policy.loop_bias=$BIAS" exec $HERE/../stakes_distill/run.sh
