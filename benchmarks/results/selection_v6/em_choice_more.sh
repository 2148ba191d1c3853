#!/usr/bin/env bash
# plan.md (session 35, exploratory, for session 36): em_choice_long resumed exactly to 105 min of training in
# all (30 more), on copies of its run folder and dataset; training only. Its validation by the session-35 rule
# is left to the next session; nothing is shipped from it this session.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
RUN=/work/runs/em_choice_more
if [ ! -e $RUN ]; then
  cp -r /work/runs/em_choice_long $RUN
  rm -rf /work/runs/data_em_choice_more && cp -r /work/runs/data_em_choice_long /work/runs/data_em_choice_more
fi
cd /work/train_code32
export PYTHONPATH=/work/train_code32
nice -n 5 /work/main/.venv/bin/explore-rl-train scene=building slam=model graph.features=extended \
  scene.building.lot_probability=0.5 scene.building.size_min=22.0 scene.building.lot_gap_probability=0.5 \
  "scene.building.lot_lane_width=[4.0,7.0]" "scene.building.lot_car_pitch=[3.5,6.5]" \
  "env.train_layouts=[0,1000]" collector.workers=2 train.max_minutes=105 train.snapshot_every=40 \
  algo.a2c_coef=0 algo.distill_coef=1 algo.distill_target=em_choice algo.dagger_steps=8 algo.lr=3e-4 \
  train.init_actor=/work/main/policies/buildings_sparse_distill/actor.pt \
  train.dataset=/work/runs/data_em_choice_more train.progress_bar=false out=$RUN resume=true
