#!/usr/bin/env bash
# plan.md: the shipped policy and EM on held-out buildings 2020-2119 (one trial each, slam=icp, 250 m), two
# streams of one in-process worker (even / odd seeds). Runs in /work/runs/zs_b100/{even,odd}.
set -e
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
COMMON="scene=building slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 \
  evaluate.policies=[learned,em] evaluate.progress_bar=false evaluate.workers=1"
EVEN=$(seq -s, 2020 2 2118)
ODD=$(seq -s, 2021 2 2119)
$EVAL -m $COMMON scene.seed=$EVEN out=/work/runs/zs_b100/even > /work/runs/zs_b100_even.log 2>&1 &
$EVAL -m $COMMON scene.seed=$ODD out=/work/runs/zs_b100/odd > /work/runs/zs_b100_odd.log 2>&1 &
wait
