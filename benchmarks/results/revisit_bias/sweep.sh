#!/usr/bin/env bash
# plan.md, session 42's addendum: the shipped actor with revisit_bias=B (BIAS, one value per call) on the
# validation buildings 1010-1039, val.sh's config, in two streams: /work/runs/rb_sweep_B_val/building_SEED.
set -e
BIAS=${BIAS:?give BIAS=value}
HERE=$(cd "$(dirname "$0")" && pwd)
CANDIDATE=/work/main/policies/buildings_sparse_em_choice/actor.pt NAME=rb_sweep_$BIAS SET=${SET:-val} \
  EXTRA="policy.revisit_bias=$BIAS" exec $HERE/../stakes_distill/run.sh
