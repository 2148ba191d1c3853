#!/usr/bin/env bash
# plan.md, session 71: DAgger on garage-like lots mixed into the building family, chosen on validation lots and
# validation buildings together. Stages, in order (each named before any runs):
#   collect   the shipped default in the loop (greedy), slam=model, training seeds of the building family with half of
#             them garage-like lots (session 70's lot kind), EM's reward of every frontier (/work/data/s71_glots,
#             collect_s71_glots.log; stops starting episodes after 40 min)
#   train     EM-choice distillation (not A2C) from the shipped actor on its training split, 4,000 steps:
#             actors/s71_glots.pt, late_probe_s71_glots.log
#   screen    the new actor against the shipped one on the held-out decisions, paired (one_step_s71_glots_vs_shipped.log;
#             descriptive)
#   screen_kinds  the same with the collection's plans (its area terciles right, and lots against buildings):
#             one_step_s71_glots_vs_shipped_kinds.log (descriptive, added after the lots' outcome)
#   default_lots  the shipped default on the lots 1110-1139, the 30 it has not run (/work/runs/stop85_glots_learned,
#             beside its 1050-1109; SETS=glots_val90 study.sh joins all 90 with EM's)
#   val_lots  the new actor, learned only, on the 90 garage-like validation lots 1050-1139
#             (/work/runs/stop85_glots71_learned; SETS=glots71_val90 study.sh, REFS=glots_val90 direct.sh glots71_val90)
#   val_bldg  the same on the 90 validation buildings 1010-1099 (/work/runs/stop85_dagger71_val90; SETS=dagger71_val90
#             study.sh, REFS=dagger9k_val90 direct.sh dagger71_val90)
#   icp_lots  (added after the screen by kind) the shipped actor in the loop under slam=icp on garage-like lots of the
#             training seeds (the validation lots' kind and size), EM's labels: /work/data/s71_icp_lots,
#             collect_s71_icp_lots.log; stops starting episodes after 20 min
#   screen_icp  the new actor against the shipped one on those icp lot states (one_step_s71_icp_lots.log; the held-out
#             layouts alone: one_step_s71_icp_lots_held_out.log)
#   bash dagger_s71.sh train screen default_lots val_lots val_bldg
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
DATA=${DATA:-/work/data/s71_glots}
SHIPPED=policies/buildings_dagger_em_choice/actor.pt
ACTOR=$HERE/actors/s71_glots.pt
GARAGE_LIKE="scene.building.lot_lane_width=[2.0,4.5] scene.building.lot_car_pitch=[5.5,6.5] \
scene.building.lot_gap_probability=0.05"
source $HERE/../keep.sh
in_repo_niced
stage_collect() {
  $PY benchmarks/collect_decisions.py --out $DATA --scene building --layouts 0 1000 --tasks 400 --max-decisions 200 \
    --workers 2 --actor $SHIPPED --minutes ${MINUTES:-40} \
    --set scene.building.lot_probability=0.5 $GARAGE_LIKE > $HERE/collect_s71_glots.log 2>&1
}
stage_train() {
  $PY $HERE/late_probe.py $DATA --arm all --actor $SHIPPED --steps 4000 --out $ACTOR > $HERE/late_probe_s71_glots.log
}
stage_screen() {  # descriptive: the new actor against the shipped one on the held-out decisions, paired
  $PY $HERE/one_step.py $DATA --held-out --actor $ACTOR --versus $SHIPPED > $HERE/one_step_s71_glots_vs_shipped.log
}
stage_screen_kinds() {  # descriptive, added after the lots' outcome: the same screen with the collection's plans, by kind
  $PY $HERE/one_step.py $DATA --held-out --actor $ACTOR --versus $SHIPPED \
    --set scene.building.lot_probability=0.5 $GARAGE_LIKE > $HERE/one_step_s71_glots_vs_shipped_kinds.log
}
LOTS_ONLY="scene.building.lot_probability=1 scene.building.size_min=28 scene.building.size_max=32 $GARAGE_LIKE"
stage_icp_lots() {  # added after the screen by kind: EM-labelled icp states of validation-like lots (training seeds)
  $PY benchmarks/collect_decisions.py --out ${ICP_DATA:-/work/data/s71_icp_lots} --scene building --layouts 0 1000 \
    --tasks 100 --max-decisions 200 --workers 2 --actor $SHIPPED --minutes ${MINUTES:-20} \
    --set slam=icp explore.travel_budget=600 $LOTS_ONLY > $HERE/collect_s71_icp_lots.log 2>&1
}
stage_screen_icp() {  # the screen on those icp lot states: all of them, and the held-out layouts alone
  $PY $HERE/one_step.py ${ICP_DATA:-/work/data/s71_icp_lots} --actor $ACTOR --versus $SHIPPED --set $LOTS_ONLY \
    > $HERE/one_step_s71_icp_lots.log
  $PY $HERE/one_step.py ${ICP_DATA:-/work/data/s71_icp_lots} --held-out --actor $ACTOR --versus $SHIPPED \
    --set $LOTS_ONLY > $HERE/one_step_s71_icp_lots_held_out.log
}
stage_default_lots() { garage_like_lots 1110 1139 glots; }
stage_val_lots() { garage_like_lots 1050 1139 glots71 "policy.checkpoint=$ACTOR"; }
stage_val_bldg() {
  stop85 POLICIES=[learned] FIRST=1010 LAST=1099 OUT=/work/runs/stop85_dagger71_val90 EXTRA="policy.checkpoint=$ACTOR"
}
run_stages "collect train screen screen_kinds default_lots val_lots val_bldg icp_lots screen_icp" "$@"
