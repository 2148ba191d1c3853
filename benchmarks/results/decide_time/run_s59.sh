#!/usr/bin/env bash
# Session 59: the measurements after the runner's ms_decide fix, the windowed grid graph and the map error at once,
# one after the other on a quiet machine (uptime before and after each): bench_decision_real (learned vs EM on the same
# street/garage states), bench_env (long office: issue 22's decisions/s), bench_explore (metrics fast vs reference).
cd "$(dirname "$0")/../../.."
S=benchmarks/results/decide_time
for run in "bench_decision_real.py" "bench_env.py" "bench_explore.py"; do
  name=$(basename $run .py)
  { echo "uptime at start: $(uptime)"; .venv/bin/python benchmarks/$run; echo "uptime at end: $(uptime)"; } \
    > $S/${name}_s59.log 2>&1
done
