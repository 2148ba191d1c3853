#!/usr/bin/env bash
# plan.md (yardstick): nearest frontier on the buildings run.sh played, the same config; two streams of one
# in-process worker. Runs in /work/runs/zs_b100_nearest/{even,odd}.
set -e
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
COMMON="scene=building slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 \
  evaluate.policies=[nearest] evaluate.progress_bar=false evaluate.workers=1"
EVEN=${EVEN:-$(seq -s, 2020 2 2118)}
ODD=${ODD:-$(seq -s, 2021 2 2119)}
$EVAL -m $COMMON scene.seed=$EVEN out=/work/runs/zs_b100_nearest/even > /work/runs/zs_b100_nearest_even.log 2>&1 &
$EVAL -m $COMMON scene.seed=$ODD out=/work/runs/zs_b100_nearest/odd > /work/runs/zs_b100_nearest_odd.log 2>&1 &
wait
