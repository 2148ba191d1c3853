#!/usr/bin/env bash
# plan.md's third candidate: 25 min of DAgger from the wide actor (code frozen at the session-32 start, as the
# default's run), after the whole-exploration runs; then its 10-decision validation (cached baselines).
set -e
while pgrep -f "run.sh (em|learned)" > /dev/null; do sleep 20; done
rm -rf /work/runs/data_dagger_wide && cp -r /work/runs/data_dagger_sparse /work/runs/data_dagger_wide
cd /work/train_code32
export PYTHONPATH=/work/train_code32
nice -n 5 /work/main/.venv/bin/explore-rl-train scene=building slam=model graph.features=extended model.hidden=256 \
  scene.building.lot_probability=0.5 scene.building.size_min=22.0 scene.building.lot_gap_probability=0.5 \
  "scene.building.lot_lane_width=[4.0,7.0]" "scene.building.lot_car_pitch=[3.5,6.5]" \
  "env.train_layouts=[0,1000]" collector.workers=2 train.max_minutes=25 train.snapshot_every=40 \
  algo.a2c_coef=0 algo.distill_coef=1 algo.dagger_steps=8 algo.lr=3e-4 \
  train.init_actor=/work/main/benchmarks/results/selection_v5/candidate_wide_actor.pt \
  train.dataset=/work/runs/data_dagger_wide train.progress_bar=false out=/work/runs/dagger_wide
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --policy /work/runs/dagger_wide/checkpoints/last.pt"
OFFICE="--layouts 1000 1001 1002 1003 1004 1005 1006 1007 1008 1009 --starts 3 --max-decisions 10 --workers 2 --set graph.features=extended"
BUILD="--scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --workers 2 --set graph.features=extended"
LOTS="$BUILD scene.building.lot_probability=1"
SPARSE="$LOTS scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
for kind in office building lots sparse; do
  out=/work/runs/val/$kind/dagger_wide_s34
  mkdir -p $out
  cp /work/runs/val/$kind/dagger_sparse_last/episodes.jsonl $out/
  args=$OFFICE; [ $kind = building ] && args=$BUILD; [ $kind = lots ] && args=$LOTS; [ $kind = sparse ] && args=$SPARSE
  echo "== dagger_wide $kind"
  $PY $args --out $out
done
