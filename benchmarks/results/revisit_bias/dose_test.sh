#!/usr/bin/env bash
# plan.md second addendum (exploratory): the shipped actor with revisit_bias=0.5 on held-out buildings 2020-2119,
# the config of test.sh, two streams (even / odd seeds), cut at 11:20 UTC. Runs in /work/runs/rb_dose_test/{even,odd}.
set -e
BIAS=${BIAS:-0.5}
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
COMMON="scene=building slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 \
  evaluate.policies=[learned] evaluate.progress_bar=false evaluate.workers=1 policy.revisit_bias=$BIAS"
$EVAL -m $COMMON scene.seed=$(seq -s, 2020 2 2118) out=/work/runs/rb_dose_test/even > /work/runs/rb_dose_test_even.log 2>&1 &
$EVAL -m $COMMON scene.seed=$(seq -s, 2021 2 2119) out=/work/runs/rb_dose_test/odd > /work/runs/rb_dose_test_odd.log 2>&1 &
wait
