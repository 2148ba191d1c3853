#!/usr/bin/env bash
# plan.md (session 56). Offline EM-choice distillation (not A2C) from the shipped actor on the grown dataset's
# training split, each fine-tuned actor then scored against the shipped actor on the held-out layouts, paired
# (one_step.py --held-out --versus). Two stages:
#   bash dagger_s56.sh arms   steps 2-3: 3,000 steps uniform and late-weighted (--late-repeat 2), and session 55's
#                             arm all: dagger_s56.log, one_step_s56_{shipped,uniform,late2,s55all}*.log
#   bash dagger_s56.sh curve  the addenda's learning curve: a seeded quarter and half of the episodes (3,000 steps),
#                             all with 9,000 steps, and that actor continued 9,000 more (18,000 in all):
#                             curve_s56.log, one_step_s56_{q25,q50,all9k,all18k}_vs_shipped.log
#   bash dagger_s56.sh round2 session 58's addendum: all9k's recipe unchanged on the dataset grown by a second DAgger
#                             round (the new default in the loop), scored against actors/s56_all9k.pt and the previous
#                             default: round2_s58.log, one_step_s58_round2_vs_{all9k,shipped}.log
set -e
cd "$(dirname "$0")/../../.."  # the repository
S=benchmarks/results/stop_coverage
DATA=${DATA:-/work/data/s55_phases}
SHIPPED=policies/buildings_sparse_em_choice/actor.pt
PY="nice -n 5 .venv/bin/python"
ERR=/work/runs/dagger_s56.err
versus() {  # versus NAME ACTOR: the actor against the shipped one on the held-out decisions
  $PY $S/one_step.py $DATA --held-out --actor $2 --versus $SHIPPED > $S/one_step_s56_$1_vs_shipped.log 2>> $ERR
}
case ${1:?"give a stage: arms, curve or round2"} in
  arms)
    {
      $PY $S/late_probe.py $DATA --arm all --steps 3000 --out /work/runs/s56_uniform.pt
      $PY $S/late_probe.py $DATA --arm all --late-repeat 2 --steps 3000 --out /work/runs/s56_late2.pt
    } > $S/dagger_s56.log 2> $ERR
    $PY $S/one_step.py $DATA --held-out --actor $SHIPPED > $S/one_step_s56_shipped.log 2>> $ERR
    versus uniform /work/runs/s56_uniform.pt
    versus late2 /work/runs/s56_late2.pt
    versus s55all /work/runs/s55_late_probe_all.pt;;
  curve)
    : > $S/curve_s56.log
    for arm in q25 q50 all9k all18k; do
      case $arm in
        q25) opts="--fraction 0.25 --steps 3000";; q50) opts="--fraction 0.5 --steps 3000";;
        all9k) opts="--steps 9000";; all18k) opts="--actor /work/runs/s56_all9k.pt --steps 9000";;
      esac
      $PY $S/late_probe.py $DATA --arm all $opts --out /work/runs/s56_$arm.pt >> $S/curve_s56.log 2>> $ERR
      versus $arm /work/runs/s56_$arm.pt
    done;;
  round2)
    $PY $S/late_probe.py $DATA --arm all --steps 9000 --out /work/runs/s58_round2.pt > $S/round2_s58.log 2>> $ERR
    $PY $S/one_step.py $DATA --held-out --actor /work/runs/s58_round2.pt --versus $S/actors/s56_all9k.pt \
      > $S/one_step_s58_round2_vs_all9k.log 2>> $ERR
    $PY $S/one_step.py $DATA --held-out --actor /work/runs/s58_round2.pt --versus $SHIPPED \
      > $S/one_step_s58_round2_vs_shipped.log 2>> $ERR;;
  *) echo "stage $1: give arms, curve or round2" >&2; exit 2;;
esac
echo done >> $ERR
