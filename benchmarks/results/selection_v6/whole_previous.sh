#!/usr/bin/env bash
# plan.md: the two previous defaults' whole explorations (after run_em_seed1.sh), paired with run.sh's EM runs.
set -e
while pgrep -f "run_em_seed1" > /dev/null; do sleep 20; done
cd /work/main/benchmarks/results/selection_v6
R=/work/runs/val_whole
for name in buildings_lots_distill buildings_office_distill; do
  ./run.sh learned $name /work/main/policies/$name/actor.pt > ${name}_whole.log 2>&1
  /work/main/.venv/bin/python /work/main/benchmarks/study_zero_shot.py $R/buildings_$name $R/sparse_$name \
    --reference $R/buildings_em $R/sparse_em --pool val_whole_$name --out targets_$name > study_$name.log 2>&1
done
