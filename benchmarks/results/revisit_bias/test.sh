#!/usr/bin/env bash
# plan.md step 2: the actor with the calibrated revisit prior on the held-out buildings 2020-2119 (the config of
# zero_shot_buildings_100/run.sh, whose EM and shipped-actor trials it is paired with). Runs in /work/runs/rb_test.
set -e
BIAS=${BIAS:-0.1}
nice -n 5 /work/main/.venv/bin/explore-rl-eval -m scene=building slam=icp graph.max_nodes=1024 evaluate.trials=1 \
  explore.travel_budget=250 evaluate.policies=[learned] evaluate.progress_bar=false evaluate.workers=1 \
  policy.revisit_bias=$BIAS scene.seed=$(seq -s, 2020 2119) out=/work/runs/rb_test
