#!/usr/bin/env bash
# Session 75: do today's code and machine reproduce EM's stored validation trials? EM's trial 0 (seed 0, the stop-85
# config) on buildings 1041 (runs/val2) and 1010 (runs/val) again, then each run's decisions, travel, explored
# fraction, map error and loop closures beside the stored trial's (rerun_check_s75.log).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
for seed in 1041 1010; do
  $HERE/../../../.venv/bin/explore-rl-eval scene=building slam=icp graph.max_nodes=4096 evaluate.trials=1 \
    explore.travel_budget=600 evaluate.progress_bar=false evaluate.workers=1 "evaluate.policies=[em]" scene.seed=$seed \
    out=/work/runs/em_rerun_check/building_$seed > /dev/null 2>&1
done
$PY - $HERE <<'PY' > $HERE/rerun_check_s75.log
import json, sys
here = sys.argv[1]
keys = ("decisions", "travel_m", "explored", "map_error_m", "loop_closures")
for building, stored in (("building_1041", "val2"), ("building_1010", "val")):
    old = next(json.loads(line) for line in open(f"{here}/runs/{stored}/{building}/trials.jsonl")
               if json.loads(line)["policy"] == "em")
    new = json.loads(open(f"/work/runs/em_rerun_check/{building}/trials.jsonl").readline())
    print(json.dumps({"building": building, "stored": {k: old[k] for k in keys}, "rerun": {k: new[k] for k in keys},
                      "identical": all(old[k] == new[k] for k in keys)}))
PY
