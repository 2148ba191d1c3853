#!/usr/bin/env bash
# plan.md, session 69 step 6: a garage-like validation pool: the sparse-lot buildings of selection_v6 (validation seeds,
# never trained or tested on) with the stop-85 config, EM and the shipped default in one run per building (resumable:
# finished buildings are skipped): /work/runs/stop85_lots_val/building_SEED; SETS=lots_val study.sh keeps them in
# runs/lots_val (study_lots_val.log, by_coverage_lots_val.log, phases_lots_val.log).
#   bash lots_s69.sh            seeds 1010-1039
#   FIRST=1040 LAST=1069 bash lots_s69.sh   more of them
# Step 7: GAP=g (lot_gap_probability, default 0.5) POLICIES=[em] OUT=DIR: other lots, e.g. denser rows where icp may
# hold as in the garage (EM's map error first).
# Session 70: SIZE=[min,max] LANE=[min,max] PITCH=[min,max] (scene.building.size_min/max, lot_lane_width,
# lot_car_pitch; defaults the session-69 pool's), e.g. the garage-like lots of plan.md session 70 step 2;
# EXTRA="key=value ...": more overrides after the lot's (e.g. a decision-time prior, step 4).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
SIZE=${SIZE:-[28,35]}; SIZE=${SIZE#[}; SIZE=${SIZE%]}
LOTS="scene.building.lot_probability=1 scene.building.size_min=${SIZE%,*} scene.building.size_max=${SIZE#*,} \
scene.building.lot_lane_width=${LANE:-[6.5,7.0]} scene.building.lot_car_pitch=${PITCH:-[6.0,6.5]} \
scene.building.lot_gap_probability=${GAP:-0.5}"
stop85 FIRST=${FIRST:-1010} LAST=${LAST:-1039} POLICIES=${POLICIES:-[learned,em]} OUT=${OUT:-/work/runs/stop85_lots_val} \
  EXTRA="$LOTS ${EXTRA:-}"
