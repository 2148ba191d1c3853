#!/usr/bin/env bash
# plan.md (session 36): em_choice distillation with DAgger from a random initialisation, 120 min in all
# (25 min office, then 95 min on the sparse-lots building family), frozen session-32 code; then the
# 10-decision validation of the last actor (cached baselines) and its held-out test, once.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
RUN1=/work/runs/scratch_office
RUN2=/work/runs/scratch_sparse
DATA=/work/runs/data_scratch
cd /work/train_code32
export PYTHONPATH=/work/train_code32
TRAIN="nice -n 5 /work/main/.venv/bin/explore-rl-train slam=model graph.features=extended collector.workers=2
  train.snapshot_every=40 train.frames=1000000 algo.a2c_coef=0 algo.distill_coef=1 algo.distill_target=em_choice
  algo.dagger_steps=8 train.dataset=$DATA train.progress_bar=false env.train_layouts=[0,1000]"
if [ ! -e $RUN1/checkpoints/last.pt ] || [ ! -e $RUN2 ]; then
  $TRAIN scene=office train.max_minutes=25 algo.lr=1e-3 out=$RUN1 $([ -e $RUN1/checkpoints/last.pt ] && echo resume=true)
fi
$TRAIN scene=building scene.building.lot_probability=0.5 scene.building.size_min=22.0 \
  scene.building.lot_gap_probability=0.5 "scene.building.lot_lane_width=[4.0,7.0]" \
  "scene.building.lot_car_pitch=[3.5,6.5]" train.max_minutes=95 algo.lr=3e-4 \
  train.init_actor=$RUN1/checkpoints/last.pt out=$RUN2 $([ -e $RUN2/checkpoints/last.pt ] && echo resume=true)
ACTOR=$RUN2/checkpoints/last.pt
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --policy $ACTOR"
OFFICE="--layouts 1000 1001 1002 1003 1004 1005 1006 1007 1008 1009 --starts 3 --max-decisions 10 --workers 2 --set graph.features=extended"
BUILD="--scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --workers 2 --set graph.features=extended"
LOTS="$BUILD scene.building.lot_probability=1"
SPARSE="$LOTS scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
for kind in office building lots sparse; do
  out=/work/runs/val/$kind/scratch_s36
  mkdir -p $out
  cp /work/runs/val/$kind/dagger_sparse_last/episodes.jsonl $out/
  args=$OFFICE; [ $kind = building ] && args=$BUILD; [ $kind = lots ] && args=$LOTS; [ $kind = sparse ] && args=$SPARSE
  echo "== scratch $kind"
  $PY $args --out $out
done
TEST="$PY --max-decisions 10 --workers 2 --set graph.features=extended"
for kind in office building; do mkdir -p /work/runs/test36/$kind && cp /work/runs/test33/$kind/episodes.jsonl /work/runs/test36/$kind/; done
echo "== test office"
$TEST --layouts 2000 2001 --starts 9 --out /work/runs/test36/office
echo "== test building"
$TEST --scene building --layouts 2000 2001 2002 2003 2004 --starts 4 --out /work/runs/test36/building
echo "== done"
