#!/usr/bin/env bash
# plan.md (session 56, step 2-3): from the shipped actor, 3,000 offline steps of EM-choice distillation (not A2C) on
# every training-split decision of the grown dataset, uniform and late-weighted (--late-repeat 2); then each of them
# and session 55's arm all (the actor in the loop of the growth) against the shipped actor on the held-out layouts,
# paired (one_step.py --held-out --versus): dagger_s56.log, one_step_s56_{shipped,uniform,late2,s55all}*.log
set -e
cd "$(dirname "$0")/../../.."  # the repository
S=benchmarks/results/stop_coverage
DATA=${DATA:-/work/data/s55_phases}
SHIPPED=policies/buildings_sparse_em_choice/actor.pt
PY="nice -n 5 .venv/bin/python"
ERR=/work/runs/dagger_s56.err
{
  $PY $S/late_probe.py $DATA --arm all --steps 3000 --out /work/runs/s56_uniform.pt
  $PY $S/late_probe.py $DATA --arm all --late-repeat 2 --steps 3000 --out /work/runs/s56_late2.pt
} > $S/dagger_s56.log 2> $ERR
$PY $S/one_step.py $DATA --held-out --actor $SHIPPED > $S/one_step_s56_shipped.log 2>> $ERR
for arm in uniform late2 s55all; do
  actor=/work/runs/s56_$arm.pt; [ $arm = s55all ] && actor=/work/runs/s55_late_probe_all.pt
  $PY $S/one_step.py $DATA --held-out --actor $actor --versus $SHIPPED > $S/one_step_s56_${arm}_vs_shipped.log 2>> $ERR
done
echo done >> $ERR
