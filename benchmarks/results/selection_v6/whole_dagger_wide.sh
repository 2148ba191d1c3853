#!/usr/bin/env bash
# plan.md: the DAgger-from-wide candidate's whole explorations (after its training and 10-decision validation),
# paired with run.sh's EM runs; then the pooled figures of all candidates.
set -e
while pgrep -f "\./dagger_wide\.sh" > /dev/null; do sleep 20; done
cd /work/main/benchmarks/results/selection_v6
./run.sh learned dagger_wide /work/runs/dagger_wide/checkpoints/last.pt > dagger_wide_whole.log 2>&1
R=/work/runs/val_whole
/work/main/.venv/bin/python /work/main/benchmarks/study_zero_shot.py $R/buildings_dagger_wide $R/sparse_dagger_wide \
  --reference $R/buildings_em $R/sparse_em --pool val_whole_dagger_wide --out targets_dagger_wide > study_dagger_wide.log 2>&1
