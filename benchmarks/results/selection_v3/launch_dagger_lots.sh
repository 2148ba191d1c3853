#!/usr/bin/env bash
# Online distillation with DAgger on the building family with parking lots (lot_probability 0.4),
# seeds [0,1000), starting from the shipped buildings_office_distill actor and its office DAgger
# dataset (copied), code frozen at the session-32 start commit.
cd /work/train_code32
export PYTHONPATH=/work/train_code32
exec nice -n 12 /work/main/.venv/bin/explore-rl-train scene=building slam=model graph.features=extended \
  scene.building.lot_probability=0.4 \
  "env.train_layouts=[0,1000]" collector.workers=2 train.max_minutes=40 train.snapshot_every=40 \
  algo.a2c_coef=0 algo.distill_coef=1 algo.dagger_steps=8 algo.lr=3e-4 \
  train.init_actor=/work/main/policies/buildings_office_distill/actor.pt train.dataset=/work/runs/data_dagger_lots \
  train.progress_bar=false out=/work/runs/dagger_lots
