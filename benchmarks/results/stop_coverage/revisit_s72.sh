#!/usr/bin/env bash
# Session 72 (plan.md, steps 3-4): which of EM's choices the actor misses, and can a weight on EM's revisiting
# decisions teach the lots' revisit rate? On session 71's DAgger data (/work/data/s71_glots, dagger_s71.sh collect).
#   revisit   revisit_choice.py, held out and in sample, the shipped and session 71's actors: revisit_choice_s72*.log
#             (and on the icp lot states of dagger_s71.sh icp_lots: revisit_choice_s72_icp_lots.log)
#   train     EM-choice distillation (not A2C) from actors/s71_glots.pt with --revisit-repeat 3, 4,000 steps:
#             actors/s72_revisit3.pt, late_probe_s72_revisit3.log
#   screen    the new actor against session 71's: revisit_choice_s72_revisit3.log, one_step_s72_revisit3_kinds.log
#   val_lots  added after the screen (plan.md step 5): the new actor on session 70's 90 garage-like lots 1050-1139
#             (/work/runs/stop85_glots72_learned; SETS=glots72_val90 study.sh, REFS=glots_val90 direct.sh glots72_val90)
#   val_bldg  the new actor on the 90 validation buildings 1010-1099 (/work/runs/stop85_dagger72_val90;
#             SETS=dagger72_val90 study.sh, REFS=dagger9k_val90 direct.sh dagger72_val90)
#   train_lot, screen_lot, val_lots_lot, val_bldg_lot  plan step 7, added after val_bldg's outcome: the weight on lot
#             decisions only (--revisit-kind lot), actors/s72_lotrevisit3.pt; logs *_s72_lotrevisit3*; sets glotsL3_val90
#             (/work/runs/stop85_glotsL3_learned) and dagger73_val90 (/work/runs/stop85_dagger73_val90)
#   named    plan step 8: the validation choice (the lot-only arm) in the street and the garage, 50 trials each
#            (/work/runs/stop85_street_garage_lotrevisit72; SETS=street_garage50_lotrevisit72 study.sh)
#   named_garage  session 73: the garage alone, for a named run whose street finished and whose garage was cut (its
#            partial log belongs to the sweep's config, so it cannot resume outside the sweep): 50 new trials into
#            /work/runs/stop85_garage_lotrevisit72/0_garage, then moved to the named run's 1_garage
#   bash revisit_s72.sh revisit train screen val_lots val_bldg
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
DATA=${DATA:-/work/data/s71_glots}
SHIPPED=policies/buildings_dagger_em_choice/actor.pt
S71=$HERE/actors/s71_glots.pt
ACTOR=$HERE/actors/s72_revisit3.pt
GARAGE_LIKE="scene.building.lot_lane_width=[2.0,4.5] scene.building.lot_car_pitch=[5.5,6.5] \
scene.building.lot_gap_probability=0.05"
FAMILY="scene.building.lot_probability=0.5 $GARAGE_LIKE"
LOTS_ONLY="scene.building.lot_probability=1 scene.building.size_min=28 scene.building.size_max=32 $GARAGE_LIKE"
source $HERE/../keep.sh
in_repo_niced
choices() {  # choices ACTOR LOG [ARGS]: revisit_choice.py of ACTOR on the data, held out
  local actor=$1 log=$2; shift 2
  $PY $HERE/revisit_choice.py $DATA --actor $actor --set $FAMILY "$@" > $HERE/$log
}
stage_revisit() {
  choices $SHIPPED revisit_choice_s72_shipped.log
  choices $S71 revisit_choice_s72_s71.log
  choices $S71 revisit_choice_s72_s71_training.log --training
  $PY $HERE/revisit_choice.py ${ICP_DATA:-/work/data/s71_icp_lots} --actor $S71 --set $LOTS_ONLY \
    > $HERE/revisit_choice_s72_icp_lots.log
}
stage_train() {
  $PY $HERE/late_probe.py $DATA --arm all --actor $S71 --revisit-repeat 3 --steps 4000 --out $ACTOR \
    > $HERE/late_probe_s72_revisit3.log
}
stage_screen() {
  choices $ACTOR revisit_choice_s72_revisit3.log
  $PY $HERE/one_step.py $DATA --held-out --actor $ACTOR --versus $S71 --set $FAMILY > $HERE/one_step_s72_revisit3_kinds.log
}
stage_val_lots() { garage_like_lots 1050 1139 glots72 "policy.checkpoint=$ACTOR"; }
stage_val_bldg() {
  stop85 POLICIES=[learned] FIRST=1010 LAST=1099 OUT=/work/runs/stop85_dagger72_val90 EXTRA="policy.checkpoint=$ACTOR"
}
LOT_ACTOR=$HERE/actors/s72_lotrevisit3.pt
stage_train_lot() {
  $PY $HERE/late_probe.py $DATA --arm all --actor $S71 --revisit-repeat 3 --revisit-kind lot --set $FAMILY \
    --steps 4000 --out $LOT_ACTOR > $HERE/late_probe_s72_lotrevisit3.log
}
stage_screen_lot() {
  choices $LOT_ACTOR revisit_choice_s72_lotrevisit3.log
  $PY $HERE/one_step.py $DATA --held-out --actor $LOT_ACTOR --versus $S71 --set $FAMILY \
    > $HERE/one_step_s72_lotrevisit3_kinds.log
}
stage_val_lots_lot() { garage_like_lots 1050 1139 glotsL3 "policy.checkpoint=$LOT_ACTOR"; }
stage_val_bldg_lot() {
  stop85 POLICIES=[learned] FIRST=1010 LAST=1099 OUT=/work/runs/stop85_dagger73_val90 EXTRA="policy.checkpoint=$LOT_ACTOR"
}
named_run() {  # named_run OUT [SCENES]: the lot-only arm, 50 trials per scene of street_garage.sh (default both)
  SCENES=${2:-street,garage} SEED=0 TRIALS=50 POLICIES=[learned] EXTRA="policy.checkpoint=$LOT_ACTOR" OUT=$1 \
    bash $HERE/street_garage.sh
}
stage_named() { named_run /work/runs/stop85_street_garage_lotrevisit72; }
stage_named_garage() {
  local named=/work/runs/stop85_street_garage_lotrevisit72 alone=/work/runs/stop85_garage_lotrevisit72
  [ -e $named/0_street/trials.jsonl ] || { echo "$named/0_street has no finished street: run the stage named" >&2; exit 2; }
  named_run $alone garage
  rm -rf $named/1_garage && mv $alone/0_garage $named/1_garage
}
run_stages "revisit train screen val_lots val_bldg train_lot screen_lot val_lots_lot val_bldg_lot named named_garage" "$@"
