#!/usr/bin/env bash
# plan.md: A2C (Algorithm 1 minus 50 x map-error growth) plus EM-choice distillation, from the shipped actor,
# 60 min, 2 workers, resumable (run it again: it resumes from the folder's last checkpoint): /work/runs/a2c_map_error.
set -e
cd /work/main
RUN=${RUN:-/work/runs/a2c_map_error}
RESUME=false; [ -e $RUN/checkpoints/last.pt ] && RESUME=true  # a killed run goes on where it stopped
.venv/bin/explore-rl-train scene=building slam=model graph.features=extended \
  scene.building.lot_probability=0.5 scene.building.size_min=22.0 scene.building.lot_gap_probability=0.5 \
  "scene.building.lot_lane_width=[4.0,7.0]" "scene.building.lot_car_pitch=[3.5,6.5]" \
  "env.train_layouts=[0,1000]" collector.workers=2 train.max_minutes=${MINUTES:-60} train.snapshot_every=40 \
  env.map_error_coef=50 algo.a2c_coef=1 algo.distill_coef=1 algo.distill_target=em_choice algo.dagger_steps=2 \
  algo.lr=1e-4 algo.entropy_coef=0.001 train.init_actor=policies/buildings_sparse_em_choice/actor.pt \
  train.dataset=$RUN/data train.progress_bar=false out=$RUN resume=$RESUME "$@"
