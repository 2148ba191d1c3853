#!/usr/bin/env bash
# The shipped policy against the previous default on the held-out test episodes (all from the caches of
# test_and_zero_shot.sh, nothing replayed): gap_closed difference with a paired interval (--compare).
# (It ran with benchmarks/study_learning.py as of commit 30579c6; the script now imports main's
# check_actor_features, which this frozen package lacks: rerun it from a checkout of that commit.)
cd /work/train_code32
export PYTHONPATH=/work/train_code32
for k in office building lots; do
  sc=""; st="--layouts 2000 2001 --starts 9"; set_="graph.features=extended"
  [ $k != office ] && sc="--scene building" && st="--layouts 2000 2001 2002 2003 2004 --starts 4"
  [ $k = lots ] && set_="$set_ scene.building.lot_probability=1"
  /work/main/.venv/bin/python /work/main/benchmarks/study_learning.py \
    --policy /work/main/policies/buildings_sparse_distill/actor.pt \
    --compare /work/main/policies/buildings_lots_distill/actor.pt $sc $st --max-decisions 10 --set $set_ \
    --out /work/runs/test33/$k
done
# held-out sparse lots (the cache of the default's run holds both policies and the baselines)
/work/main/.venv/bin/python /work/main/benchmarks/study_learning.py \
  --policy /work/main/policies/buildings_sparse_distill/actor.pt \
  --compare /work/main/policies/buildings_lots_distill/actor.pt --scene building \
  --layouts 2000 2001 2002 2003 2004 --starts 4 --max-decisions 10 --set graph.features=extended \
  scene.building.lot_probability=1 scene.building.size_min=28.0 scene.building.size_max=35.0 \
  "scene.building.lot_lane_width=[6.5,7.0]" "scene.building.lot_car_pitch=[6.0,6.5]" \
  scene.building.lot_gap_probability=0.5 --out /work/runs/test33/sparse_default
