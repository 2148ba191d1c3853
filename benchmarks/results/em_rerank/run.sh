#!/usr/bin/env bash
# plan.md steps 2-3: the shipped actor shortlisting K frontiers for EM (policy.em_top_k=K) on the validation
# buildings 1010-1039 (SET=val) or the held-out buildings 2020-2119 (SET=test), in stakes_distill/run.sh's two
# resumable streams and config: /work/runs/em_top_K_$SET/building_SEED.
set -e
K=${K:?give K=shortlist size}
HERE=$(cd "$(dirname "$0")" && pwd)
CANDIDATE=/work/main/policies/buildings_sparse_em_choice/actor.pt NAME=em_top_$K SET=${SET:-val} \
  EXTRA="policy.em_top_k=$K" exec $HERE/../stakes_distill/run.sh
