#!/usr/bin/env bash
# plan.md, session 65: DAgger on slam=icp states, chosen on validation only. Stages, in order (each named before any runs):
#   collect  the current default in the loop under slam=icp on training seeds, EM's reward of every frontier, the
#            stop-85 budget and the training graph size (graph.max_nodes=512, the default)
#            (/work/data/s65_icp, collect_s65_icp.log; stops starting episodes after 55 min)
#   train    EM-choice distillation (not A2C) from actors/s56_all9k.pt on its training split, 3,000 steps:
#            actors/s65_icp.pt, late_probe_s65_icp.log
#   screen   the new actor against s56_all9k on the held-out icp decisions, paired (one_step_s65_icp_vs_all9k.log;
#            descriptive)
#   val      the new actor, learned only, on the validation buildings 1010-1099 (run.sh's stop-85 config,
#            /work/runs/stop85_icp65_val90); then SETS=icp65_val90 study.sh and REFS=dagger9k_val90 direct.sh icp65_val90
#   bash icp_s65.sh train screen val
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
DATA=${DATA:-/work/data/s65_icp}
source $HERE/../keep.sh
in_repo_niced
stage_collect() {
  $PY benchmarks/collect_decisions.py --out $DATA --scene building --layouts 0 1000 --tasks 400 --max-decisions 200 \
    --workers 2 --actor $HERE/actors/s56_all9k.pt --minutes 55 \
    --set slam=icp explore.travel_budget=600 > $HERE/collect_s65_icp.log 2>&1
}
stage_train() {
  $PY $HERE/late_probe.py $DATA --arm all --actor $HERE/actors/s56_all9k.pt --steps 3000 \
    --out $HERE/actors/s65_icp.pt > $HERE/late_probe_s65_icp.log
}
stage_screen() {  # descriptive: the new actor against s56_all9k on the held-out icp decisions, paired
  $PY $HERE/one_step.py $DATA --held-out --actor $HERE/actors/s65_icp.pt --versus $HERE/actors/s56_all9k.pt \
    > $HERE/one_step_s65_icp_vs_all9k.log
}
stage_val() {
  stop85 POLICIES=[learned] FIRST=1010 LAST=1099 OUT=/work/runs/stop85_icp65_val90 \
    EXTRA="policy.checkpoint=$HERE/actors/s65_icp.pt"
}
run_stages "collect train screen val" "$@"
