#!/usr/bin/env bash
# plan.md's A/B at 4,500 steps: baseline seeds 1-2 (seed 0 = the probe's steps4500_h128), relative seeds 0-2.
cd /work/main
DATA=/work/runs/data_s33_relative
OUT=/work/runs/relative_s33
run() {  # name seed overrides...
  local name=$1 seed=$2; shift 2
  nice -n 5 .venv/bin/python benchmarks/study_data.py --dataset $DATA --features extended --sizes 1000000 \
    --steps 4500 --seed $seed --offline-only --set algo.lr=1e-3 "$@" --out $OUT/$name > $OUT/$name.log 2>&1
}
REL="model.relative_features=[path_length,frontier_size,distance]"
run steps4500_baseline_1 1 & run steps4500_relative_0 0 $REL & wait
run steps4500_baseline_2 2 & run steps4500_relative_1 1 $REL & wait
run steps4500_relative_2 2 $REL
