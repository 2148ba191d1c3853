#!/usr/bin/env bash
# plan.md (session 56, addendum 05:39): the late band's learning curve. From the shipped actor, a seeded quarter and
# half of the training episodes (3,000 steps), and all of them with 9,000 steps; each against the shipped actor on the
# held-out decisions, paired (one_step.py --held-out --versus): curve_s56.log, one_step_s56_{q25,q50,all9k}_vs_shipped.log
set -e
cd "$(dirname "$0")/../../.."  # the repository
S=benchmarks/results/stop_coverage
DATA=${DATA:-/work/data/s55_phases}
SHIPPED=policies/buildings_sparse_em_choice/actor.pt
PY="nice -n 5 .venv/bin/python"
ERR=/work/runs/curve_s56.err
: > $S/curve_s56.log
for arm in q25 q50 all9k; do
  case $arm in q25) opts="--fraction 0.25 --steps 3000";; q50) opts="--fraction 0.5 --steps 3000";;
    all9k) opts="--steps 9000";; esac
  $PY $S/late_probe.py $DATA --arm all $opts --out /work/runs/s56_$arm.pt >> $S/curve_s56.log 2>> $ERR
  $PY $S/one_step.py $DATA --held-out --actor /work/runs/s56_$arm.pt --versus $SHIPPED \
    > $S/one_step_s56_${arm}_vs_shipped.log 2>> $ERR
done
echo done >> $ERR
