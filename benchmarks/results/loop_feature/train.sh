#!/usr/bin/env bash
# plan.md addendum: the shipped policy's last stage (online DAgger of EM's choice on the building family with
# sparse lots, 2 workers) with graph.features=loops, from the offline candidate, the replay dataset seeded with the
# loops copy of /work/runs/data_scratch; resumable (run it again: it resumes from the folder's last checkpoint).
set -e
cd /work/main
RUN=${RUN:-/work/runs/lf_dagger}
DATA=${RUN}_data  # outside the run folder (a new run needs an empty one)
RESUME=false; [ -e $RUN/checkpoints/last.pt ] && RESUME=true
if [ ! -e $DATA/dataset.json ]; then
  .venv/bin/python -c "from explore_rl.trainer.dataset import DecisionDataset, derive_loops_dataset as d; \
print(d(DecisionDataset('/work/runs/data_scratch'), '$DATA')[1], 'graphs cut at max_nodes left out')"
fi
nice -n 5 .venv/bin/explore-rl-train scene=building slam=model graph.features=loops \
  scene.building.lot_probability=0.5 scene.building.size_min=22.0 scene.building.lot_gap_probability=0.5 \
  "scene.building.lot_lane_width=[4.0,7.0]" "scene.building.lot_car_pitch=[3.5,6.5]" \
  "env.train_layouts=[0,1000]" collector.workers=2 train.max_minutes=${MINUTES:-55} train.snapshot_every=40 \
  algo.a2c_coef=0 algo.distill_coef=1 algo.distill_target=em_choice algo.dagger_steps=8 algo.lr=3e-4 \
  train.init_actor=benchmarks/results/loop_feature/candidate_widened_loops_actor.pt \
  train.dataset=$DATA train.progress_bar=false out=$RUN resume=$RESUME "$@"
