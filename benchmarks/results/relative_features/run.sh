#!/usr/bin/env bash
# plan.md's offline A/B: two arms x seeds 0-2, two processes at a time (one thread each).
cd /work/main
DATA=/work/runs/data_s33_relative
OUT=/work/runs/relative_s33
run() {  # arm seed overrides...
  local arm=$1 seed=$2; shift 2
  nice -n 5 .venv/bin/python benchmarks/study_data.py --dataset $DATA --features extended --sizes 1000000 \
    --steps 1500 --seed $seed --offline-only --set algo.lr=1e-3 "$@" --out $OUT/${arm}_$seed > $OUT/${arm}_$seed.log 2>&1
}
for seed in 0 1 2; do
  run baseline $seed &
  run relative $seed "model.relative_features=[path_length,frontier_size,distance]" &
  wait
done
