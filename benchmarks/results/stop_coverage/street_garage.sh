#!/usr/bin/env bash
# plan.md, session 52 step B: EM and the shipped default in street and garage, 10 trials each, slam=icp, until 85 %
# explored or 600 m (graph.max_nodes=4096: a 600 m garage run holds ~1,500 keyframes); two workers.
# OUT: another folder (default /work/runs/stop85_street_garage, one sub-folder per scene); POLICIES=[nearest,random]
# OUT=/work/runs/stop85_street_garage_baselines: the other two policies, the same seeds (step D).
# Session 58: EXTRA="policy.checkpoint=FILE" POLICIES=[learned] OUT=/work/runs/stop85_street_garage_NAME: another
# actor on the same seeds (study.sh's set street_garage_NAME pairs it with EM's trials of runs/street_garage).
# Session 67: SEED=s TRIALS=n: n trials from seed s (trial t is seeded s + t; default seed 0, 10 trials), in the same
# scenes (scene.seed stays 0: by default it follows seed, and another scene.seed draws another street or garage).
# Session 70: SCENES=garage: one of the scenes only (its folder is then 0_garage; study.sh finds it by name).
set -e
nice -n 5 /work/main/.venv/bin/explore-rl-eval -m scene=${SCENES:-street,garage} slam=icp evaluate.policies=${POLICIES:-[learned,em]} \
  seed=${SEED:-0} scene.seed=0 evaluate.trials=${TRIALS:-10} evaluate.workers=2 evaluate.progress_bar=false explore.travel_budget=600 graph.max_nodes=4096 \
  out=${OUT:-/work/runs/stop85_street_garage} $EXTRA
