#!/usr/bin/env bash
# Session 77: does this machine repeat stored named-scene trials seed by seed? The street (street_garage.sh's config)
# for EM and the shipped default, seeds 0-1 (stored by session 67 in runs/street_garage50) and EM's seed 50 (stored by
# session 76 in runs/named200_em, the same product code), once more for EM seeds 0-1 (repeat on this machine), and
# EM's building 1010 as session 75's rerun_check_s75.sh ran it (runs/val). Log repro_s77.log: per trial, decisions,
# travel and map error, stored against rerun.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
OUT=${OUT:-/work/runs/repro_s77}
rm -rf $OUT
SCENES=street SEED=0 TRIALS=2 POLICIES=[em,learned] OUT=$OUT/street_0 bash $HERE/street_garage.sh > /dev/null 2>&1
SCENES=street SEED=0 TRIALS=2 POLICIES=[em] OUT=$OUT/street_0_again bash $HERE/street_garage.sh > /dev/null 2>&1
SCENES=street SEED=50 TRIALS=1 POLICIES=[em] OUT=$OUT/street_50 bash $HERE/street_garage.sh > /dev/null 2>&1
OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 $HERE/../../../.venv/bin/explore-rl-eval scene=building \
  slam=icp graph.max_nodes=4096 evaluate.trials=1 explore.travel_budget=600 evaluate.progress_bar=false \
  evaluate.workers=1 "evaluate.policies=[em]" scene.seed=1010 out=$OUT/building_1010 > /dev/null 2>&1
$PY - $HERE $OUT <<'PY' > $HERE/repro_s77.log
import json, sys
here, out = sys.argv[1:]
def trials(path):
    return {(t["policy"], t["seed"]): t for t in map(json.loads, open(path))}
pairs = (("session 67, street", f"{here}/runs/street_garage50/0_street/trials.jsonl", f"{out}/street_0/0_street/trials.jsonl"),
         ("this machine twice, street", f"{out}/street_0/0_street/trials.jsonl", f"{out}/street_0_again/0_street/trials.jsonl"),
         ("session 76, street", f"{here}/runs/named200_em/0_street/trials.jsonl", f"{out}/street_50/0_street/trials.jsonl"),
         ("session 75's check, building 1010", f"{here}/runs/val/building_1010/trials.jsonl", f"{out}/building_1010/trials.jsonl"))
for name, stored_path, rerun_path in pairs:
    stored, rerun = trials(stored_path), trials(rerun_path)
    for key, new in rerun.items():
        old = stored[key]
        print(json.dumps({"comparison": name, "policy": key[0], "seed": key[1],
                          **{k: [old[k], new[k]] for k in ("decisions", "travel_m", "map_error_m")},
                          "same_decisions": old["decisions"] == new["decisions"]
                          and abs(old["travel_m"] - new["travel_m"]) < 1e-6}))
PY
