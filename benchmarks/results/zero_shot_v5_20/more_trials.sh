#!/usr/bin/env bash
# plan.md: ten more zero-shot trials of the shipped policy and EM (street and garage: seeds 10-19 on the
# same scene, scene.seed=0; ten more held-out buildings 2010-2019), the same config as zero_shot_v5_10 and
# zero_shot_buildings_v5; code frozen at the session-32 start commit. Meant to wait for the test script, but
# the pattern below never matched (pgrep -f takes an extended regex, in which a backslash before the bar makes it a literal bar), so it started at once,
# alongside it (09:38).
set -e
while pgrep -f "selection_v4/test_and_zero_shot.sh\|s33/test_and_zero_shot.sh" > /dev/null; do sleep 20; done
ACTOR=/work/main/policies/buildings_sparse_distill/actor.pt
cd /work/train_code32
export PYTHONPATH=/work/train_code32
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
$EVAL -m scene=street,garage seed=10 scene.seed=0 graph.max_nodes=1024 evaluate.trials=10 \
  "evaluate.policies=[learned,em]" evaluate.progress_bar=false policy.checkpoint=$ACTOR out=/work/runs/zero_shot_v5_10b
$EVAL -m scene=building scene.seed=2010,2011,2012,2013,2014,2015,2016,2017,2018,2019 slam=icp \
  graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 "evaluate.policies=[learned,em]" \
  evaluate.progress_bar=false policy.checkpoint=$ACTOR out=/work/runs/zero_shot_buildings_v5b
