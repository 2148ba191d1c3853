#!/usr/bin/env bash
# plan.md (session 36; re-run from scratch in session 37, whose machine had none of session 36's run): em_choice
# distillation with DAgger from a random initialisation, 120 min in all (25 min office, then 95 min on the
# sparse-lots building family), frozen session-32 code; then the 10-decision validation of the last actor and
# its held-out test, once (steps.sh: cached baselines where this machine has them, else played again).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/steps.sh
RUN1=/work/runs/scratch_office
RUN2=/work/runs/scratch_sparse
DATA=/work/runs/data_scratch
date; uptime
(
cd /work/train_code32
export PYTHONPATH=/work/train_code32
TRAIN="nice -n 5 /work/main/.venv/bin/explore-rl-train slam=model graph.features=extended collector.workers=2
  train.snapshot_every=40 train.frames=1000000 algo.a2c_coef=0 algo.distill_coef=1 algo.distill_target=em_choice
  algo.dagger_steps=8 train.dataset=$DATA train.progress_bar=false env.train_layouts=[0,1000]"
if [ ! -e $RUN1/checkpoints/last.pt ] || [ ! -e $RUN2 ]; then
  $TRAIN scene=office train.max_minutes=25 algo.lr=1e-3 out=$RUN1 $([ -e $RUN1/checkpoints/last.pt ] && echo resume=true)
fi
date; uptime
$TRAIN scene=building scene.building.lot_probability=0.5 scene.building.size_min=22.0 \
  scene.building.lot_gap_probability=0.5 "scene.building.lot_lane_width=[4.0,7.0]" \
  "scene.building.lot_car_pitch=[3.5,6.5]" train.max_minutes=95 algo.lr=3e-4 \
  train.init_actor=$RUN1/checkpoints/last.pt out=$RUN2 $([ -e $RUN2/checkpoints/last.pt ] && echo resume=true)
)
date; uptime
echo "== training done"
ACTOR=$RUN2/checkpoints/last.pt
validate_10 $ACTOR scratch_s36
date; uptime
heldout_test $ACTOR /work/runs/test36
date; uptime
echo "== done"
