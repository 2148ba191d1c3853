#!/usr/bin/env bash
# plan.md (exploratory): 25 min of DAgger from the default with algo.distill_target=em_choice (code frozen at the
# session-32 start, as the default's run), then its whole explorations on the validation scenes.
set -e
rm -rf /work/runs/data_em_choice && cp -r /work/runs/data_dagger_sparse /work/runs/data_em_choice
cd /work/train_code32
export PYTHONPATH=/work/train_code32
nice -n 5 /work/main/.venv/bin/explore-rl-train scene=building slam=model graph.features=extended \
  scene.building.lot_probability=0.5 scene.building.size_min=22.0 scene.building.lot_gap_probability=0.5 \
  "scene.building.lot_lane_width=[4.0,7.0]" "scene.building.lot_car_pitch=[3.5,6.5]" \
  "env.train_layouts=[0,1000]" collector.workers=2 train.max_minutes=25 train.snapshot_every=40 \
  algo.a2c_coef=0 algo.distill_coef=1 algo.distill_target=em_choice algo.dagger_steps=8 algo.lr=3e-4 \
  train.init_actor=/work/main/policies/buildings_sparse_distill/actor.pt \
  train.dataset=/work/runs/data_em_choice train.progress_bar=false out=/work/runs/em_choice
cd /work/main/benchmarks/results/selection_v6
./run.sh learned em_choice /work/runs/em_choice/checkpoints/last.pt > em_choice_whole.log 2>&1
R=/work/runs/val_whole
PYTHONPATH= /work/main/.venv/bin/python /work/main/benchmarks/study_zero_shot.py $R/buildings_em_choice $R/sparse_em_choice \
  --reference $R/buildings_em $R/sparse_em --pool val_whole_em_choice --out targets_em_choice > study_em_choice.log 2>&1
