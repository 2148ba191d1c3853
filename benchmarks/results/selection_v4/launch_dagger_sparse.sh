#!/usr/bin/env bash
# DAgger (distillation of EM's per-frontier utility) from the new default buildings_lots_distill on the
# building family with more, larger and sparser parking lots (the plan kind that reproduced the garage's
# lean to the nearest frontier in choice_shift.py), its dataset copied; code frozen at the session-32 start.
cd /work/train_code32
export PYTHONPATH=/work/train_code32
exec nice -n 12 /work/main/.venv/bin/explore-rl-train scene=building slam=model graph.features=extended \
  scene.building.lot_probability=0.5 scene.building.size_min=22.0 scene.building.lot_gap_probability=0.5 \
  "scene.building.lot_lane_width=[4.0,7.0]" "scene.building.lot_car_pitch=[3.5,6.5]" \
  "env.train_layouts=[0,1000]" collector.workers=2 train.max_minutes=25 train.snapshot_every=40 \
  algo.a2c_coef=0 algo.distill_coef=1 algo.dagger_steps=8 algo.lr=3e-4 \
  train.init_actor=/work/main/policies/buildings_lots_distill/actor.pt train.dataset=/work/runs/data_dagger_sparse \
  train.progress_bar=false out=/work/runs/dagger_sparse
