#!/usr/bin/env bash
# Zero-shot of the wide candidate, learned policy only (EM's trials of zero_shot_v5_10 / zero_shot_buildings_v5
# are seeded and reproduced exactly across sessions 28-33, so they are paired by symlink); code frozen at the
# session-32 start. Reported, not used to choose (selection_v4's addendum).
set -e
ACTOR=/work/main/benchmarks/results/selection_v5/candidate_wide_actor.pt
cd /work/train_code32
export PYTHONPATH=/work/train_code32
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
$EVAL -m scene=street,garage graph.max_nodes=1024 evaluate.trials=10 "evaluate.policies=[learned]" \
  evaluate.progress_bar=false policy.checkpoint=$ACTOR out=/work/runs/zero_shot_wide_10
$EVAL -m scene=building scene.seed=2000,2001,2002,2003,2004,2005,2006,2007,2008,2009 slam=icp \
  graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 "evaluate.policies=[learned]" \
  evaluate.progress_bar=false policy.checkpoint=$ACTOR out=/work/runs/zero_shot_buildings_wide
