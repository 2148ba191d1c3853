#!/usr/bin/env bash
# plan.md's capacity probe (added after the A/B): seed 0, baseline features, 3x the steps, two widths.
cd /work/main
DATA=/work/runs/data_s33_relative
OUT=/work/runs/relative_s33
run() {  # name overrides...
  local name=$1; shift
  nice -n 5 .venv/bin/python benchmarks/study_data.py --dataset $DATA --features extended --sizes 1000000 \
    --steps 4500 --seed 0 --offline-only --set algo.lr=1e-3 "$@" --out $OUT/$name > $OUT/$name.log 2>&1
}
run steps4500_h128 &
run steps4500_h256 model.hidden=256 &
wait
