#!/usr/bin/env bash
# Session 74 (plan.md): a DAgger round of the lot-only arm on its own states. The lot-only arm
# (actors/s72_lotrevisit3.pt) met the map-error target on the fresh pool 2620-2819 but drove 10 % further than EM
# there; its one-step revisit rate on buildings looked like EM's, so the extra travel comes from the states it visits,
# which session 71's data (the default's states) never showed it. Stages, in order (each named before any runs):
#   collect   the lot-only arm in the loop (greedy), slam=model, session 71's collection config (training seeds of the
#             building family, half of them garage-like lots, EM's reward of every frontier): /work/data/s74_glots,
#             collect_s74_glots.log; stops starting episodes after MINUTES (default 35)
#   train     EM-choice distillation (not A2C) from the lot-only arm on this data's training split, the same weight
#             (lot decisions whose EM choice revisits drawn 3 times as often), 4,000 steps: actors/s74_dagger_lot.pt,
#             late_probe_s74_dagger_lot.log
#   screen    revisit rates and the greedy gap against the lot-only arm on the held-out decisions, by kind:
#             revisit_choice_s74_{lot_arm,dagger_lot}.log, one_step_s74_dagger_lot_kinds.log
#   val_lots  the new actor on session 70's 90 garage-like lots 1050-1139 (/work/runs/stop85_glots74_learned;
#             SETS=glots74_val90 study.sh, REFS=glots_val90 direct.sh glots74_val90)
#   val_bldg  the new actor on the 90 validation buildings 1010-1099 (/work/runs/stop85_dagger74_val90;
#             SETS=dagger74_val90 study.sh, REFS=dagger9k_val90 direct.sh dagger74_val90)
#   named     session 75 (plan.md step 5, if both parts of step 4 hold): the new actor in the street and the garage, 50
#             trials each, seeds 0-49 (/work/runs/stop85_street_garage_dagger74; SETS=street_garage50_dagger74 study.sh)
#   em_replicate  session 75 (plan.md's addendum, policy-independent): EM a second time on the 90 validation buildings
#             1010-1099 with the next trial's noise seed (evaluate.first_trial=1; /work/runs/stop85_em_replicate_val90),
#             against its stored trials of runs/val and runs/val2: em_replicate_val90.log, targets_em_replicate_val90
#   bash dagger_s74.sh collect train screen val_lots val_bldg
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
DATA=${DATA:-/work/data/s74_glots}
LOT_ARM=$HERE/actors/s72_lotrevisit3.pt
ACTOR=$HERE/actors/s74_dagger_lot.pt
GARAGE_LIKE="scene.building.lot_lane_width=[2.0,4.5] scene.building.lot_car_pitch=[5.5,6.5] \
scene.building.lot_gap_probability=0.05"
FAMILY="scene.building.lot_probability=0.5 $GARAGE_LIKE"
source $HERE/../keep.sh
in_repo_niced
stage_collect() {
  $PY benchmarks/collect_decisions.py --out $DATA --scene building --layouts 0 1000 --tasks 400 --max-decisions 200 \
    --workers 2 --actor $LOT_ARM --minutes ${MINUTES:-35} --set $FAMILY > $HERE/collect_s74_glots.log 2>&1
}
stage_train() {
  $PY $HERE/late_probe.py $DATA --arm all --actor $LOT_ARM --revisit-repeat 3 --revisit-kind lot --set $FAMILY \
    --steps 4000 --out $ACTOR > $HERE/late_probe_s74_dagger_lot.log
}
stage_screen() {
  $PY $HERE/revisit_choice.py $DATA --actor $LOT_ARM --set $FAMILY > $HERE/revisit_choice_s74_lot_arm.log
  $PY $HERE/revisit_choice.py $DATA --actor $ACTOR --set $FAMILY > $HERE/revisit_choice_s74_dagger_lot.log
  $PY $HERE/one_step.py $DATA --held-out --actor $ACTOR --versus $LOT_ARM --set $FAMILY \
    > $HERE/one_step_s74_dagger_lot_kinds.log
}
stage_val_lots() { garage_like_lots 1050 1139 glots74 "policy.checkpoint=$ACTOR"; }
stage_val_bldg() {
  stop85 POLICIES=[learned] FIRST=1010 LAST=1099 OUT=/work/runs/stop85_dagger74_val90 EXTRA="policy.checkpoint=$ACTOR"
}
stage_named() {
  SEED=0 TRIALS=50 POLICIES=[learned] EXTRA="policy.checkpoint=$ACTOR" OUT=/work/runs/stop85_street_garage_dagger74 \
    bash $HERE/street_garage.sh
}
stage_em_replicate() {
  stop85 POLICIES=[em] FIRST=1010 LAST=1099 OUT=/work/runs/stop85_em_replicate_val90 EXTRA="evaluate.first_trial=1"
}
run_stages "collect train screen val_lots val_bldg named em_replicate" "$@"
