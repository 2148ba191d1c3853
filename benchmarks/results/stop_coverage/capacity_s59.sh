#!/usr/bin/env bash
# plan.md (session 59 addendum): two actors from scratch, hidden 128 and 256, the same data, seed and steps, then the
# wider against the narrower on the held-out decisions, paired (one_step.py --versus). Nothing selected or shipped.
set -e
cd "$(dirname "$0")/../../.."  # the repository
S=benchmarks/results/stop_coverage
DATA=${DATA:-/work/data/s55_phases}
for hidden in 128 256; do
  .venv/bin/python benchmarks/results/loop_feature/probe.py --arm scratch --feature-sets extended --dataset $DATA \
    --hidden $hidden --seeds 0 --steps ${STEPS:-6000} --every 2000 --out /work/runs/s59_capacity_$hidden \
    > $S/capacity_s59_$hidden.log 2> /work/runs/capacity_s59_$hidden.err
done
.venv/bin/python $S/one_step.py $DATA --held-out --actor $(ls /work/runs/s59_capacity_256/*.pt | head -1) \
  --versus $(ls /work/runs/s59_capacity_128/*.pt | head -1) > $S/one_step_s59_capacity.log 2>> /work/runs/capacity_s59_256.err
