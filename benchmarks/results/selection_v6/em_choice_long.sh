#!/usr/bin/env bash
# plan.md (session 35): session 34's exploratory em_choice run resumed exactly until 75 min of training in all
# (code frozen at the session-32 start, as the default's run), then its 10-decision validation (cached
# baselines) and its whole explorations on the 20 validation scenes with two trials per scene.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
RUN=/work/runs/em_choice_long
if [ ! -e $RUN ]; then
  cp -r /work/runs/em_choice $RUN
  rm -rf /work/runs/data_em_choice_long && cp -r /work/runs/data_em_choice /work/runs/data_em_choice_long
fi
cd /work/train_code32
export PYTHONPATH=/work/train_code32
nice -n 5 /work/main/.venv/bin/explore-rl-train scene=building slam=model graph.features=extended \
  scene.building.lot_probability=0.5 scene.building.size_min=22.0 scene.building.lot_gap_probability=0.5 \
  "scene.building.lot_lane_width=[4.0,7.0]" "scene.building.lot_car_pitch=[3.5,6.5]" \
  "env.train_layouts=[0,1000]" collector.workers=2 train.max_minutes=75 train.snapshot_every=40 \
  algo.a2c_coef=0 algo.distill_coef=1 algo.distill_target=em_choice algo.dagger_steps=8 algo.lr=3e-4 \
  train.init_actor=/work/main/policies/buildings_sparse_distill/actor.pt \
  train.dataset=/work/runs/data_em_choice_long train.progress_bar=false out=$RUN resume=true
ACTOR=$RUN/checkpoints/last.pt
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --policy $ACTOR"
OFFICE="--layouts 1000 1001 1002 1003 1004 1005 1006 1007 1008 1009 --starts 3 --max-decisions 10 --workers 2 --set graph.features=extended"
BUILD="--scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --workers 2 --set graph.features=extended"
LOTS="$BUILD scene.building.lot_probability=1"
SPARSE="$LOTS scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
for kind in office building lots sparse; do
  out=/work/runs/val/$kind/em_choice_long_s35
  mkdir -p $out
  cp /work/runs/val/$kind/dagger_sparse_last/episodes.jsonl $out/
  args=$OFFICE; [ $kind = building ] && args=$BUILD; [ $kind = lots ] && args=$LOTS; [ $kind = sparse ] && args=$SPARSE
  echo "== em_choice_long $kind"
  $PY $args --out $out
done
cd /work/train_code34
export PYTHONPATH=/work/train_code34
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
SEEDS=scene.seed=1000,1001,1002,1003,1004,1005,1006,1007,1008,1009
SPARSE="scene.building.lot_probability=1 scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
for seed in 0 1; do
  COMMON="slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 evaluate.progress_bar=false seed=$seed"
  $EVAL -m scene=building $SEEDS $COMMON "evaluate.policies=[learned]" policy.checkpoint=$ACTOR out=/work/runs/val_whole/buildings_em_choice_long_seed$seed
  $EVAL -m scene=building $SEEDS $COMMON $SPARSE "evaluate.policies=[learned]" policy.checkpoint=$ACTOR out=/work/runs/val_whole/sparse_em_choice_long_seed$seed
done
echo "== done"
