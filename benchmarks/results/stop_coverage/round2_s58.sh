#!/usr/bin/env bash
# plan.md, session 58 addendum: the second DAgger round's fine-tune and its one-step score, after the collection
# (collect_decisions.py with the new default in the loop, grown into DATA): session 56's all9k recipe unchanged
# (9,000 offline steps of EM-choice distillation, not A2C, from the previous default on every training-split
# decision), then one_step.py on all held-out decisions, paired against actors/s56_all9k.pt and the previous default.
# Logs: round2_s58.log (the fine-tune's JSON line), one_step_s58_round2_vs_{all9k,shipped}.log.
set -e
cd "$(dirname "$0")/../../.."  # the repository
S=benchmarks/results/stop_coverage
DATA=${DATA:-/work/data/s55_phases}
PREVIOUS=policies/buildings_sparse_em_choice/actor.pt
PY=".venv/bin/python"
ERR=/work/runs/round2_s58.err
$PY $S/late_probe.py $DATA --arm all --steps 9000 --actor $PREVIOUS --out /work/runs/s58_round2.pt > $S/round2_s58.log 2> $ERR
$PY $S/one_step.py $DATA --held-out --actor /work/runs/s58_round2.pt --versus $S/actors/s56_all9k.pt \
  > $S/one_step_s58_round2_vs_all9k.log 2>> $ERR
$PY $S/one_step.py $DATA --held-out --actor /work/runs/s58_round2.pt --versus $PREVIOUS \
  > $S/one_step_s58_round2_vs_shipped.log 2>> $ERR
echo done >> $ERR
