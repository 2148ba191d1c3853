#!/usr/bin/env bash
# Online distillation with DAgger on office layouts [0,1000), starting from the shipped buildings_distill actor.
cd /work/train_code
export PYTHONPATH=/work/train_code
exec nice -n 12 /work/main/.venv/bin/explore-rl-train scene=office slam=model graph.features=extended \
  "env.train_layouts=[0,1000]" collector.workers=2 train.max_minutes=40 train.snapshot_every=40 \
  algo.a2c_coef=0 algo.distill_coef=1 algo.dagger_steps=8 algo.lr=3e-4 \
  train.init_actor=/work/main/policies/buildings_distill/actor.pt train.dataset=/work/runs/data_dagger_office \
  train.progress_bar=false out=/work/runs/dagger_office
