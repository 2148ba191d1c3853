#!/usr/bin/env bash
# plan.md: DAgger of EM's choice under slam=model_buildings on the default building family (no lots), from the
# shipped actor, a new dataset, 50 min; resumable (run it again: it resumes from the run's last checkpoint).
set -e
cd /work/main
RUN=${RUN:-/work/runs/tmb}
DATA=${RUN}_data  # outside the run folder (a new run needs an empty one)
RESUME=false; [ -e $RUN/checkpoints/last.pt ] && RESUME=true
nice -n 5 .venv/bin/explore-rl-train scene=building slam=model_buildings graph.features=extended \
  "env.train_layouts=[0,1000]" collector.workers=2 train.max_minutes=${MINUTES:-50} train.snapshot_every=40 \
  algo.a2c_coef=0 algo.distill_coef=1 algo.distill_target=em_choice algo.dagger_steps=8 algo.lr=3e-4 \
  train.init_actor=policies/buildings_sparse_em_choice/actor.pt \
  train.dataset=$DATA train.progress_bar=false out=$RUN resume=$RESUME "$@"
