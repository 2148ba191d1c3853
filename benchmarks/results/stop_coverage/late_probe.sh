#!/usr/bin/env bash
# plan.md (session 55, last addendum): both fine-tuning arms, then the shipped actor and both arms on the held-out
# layouts by band (one_step.py --held-out): late_probe_s55.log, one_step_held_out_{shipped,all,late}.log
set -e
cd "$(dirname "$0")/../../.."  # the repository
S=benchmarks/results/stop_coverage
for arm in all late; do
  nice -n 5 .venv/bin/python $S/late_probe.py /work/data/s55_phases --arm $arm --out /work/runs/s55_late_probe_$arm.pt
done > $S/late_probe_s55.log 2> /work/runs/late_probe_s55.err
for a in shipped all late; do
  actor=policies/buildings_sparse_em_choice/actor.pt; [ $a = shipped ] || actor=/work/runs/s55_late_probe_$a.pt
  nice -n 5 .venv/bin/python $S/one_step.py /work/data/s55_phases --held-out --actor $actor > $S/one_step_held_out_$a.log 2>> /work/runs/late_probe_s55.err
done
echo done >> /work/runs/late_probe_s55.err
