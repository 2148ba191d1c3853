#!/usr/bin/env bash
# plan.md (session 36; re-run from scratch in session 37, whose machine had none of session 36's run): em_choice
# distillation with DAgger from a random initialisation, 120 min in all (25 min office, then 95 min on the
# sparse-lots building family), frozen session-32 code; then the held-out test of the last actor, once (steps.sh:
# cached baselines where this machine has them, else played again). Since session 38 its 10-decision validation
# runs last in scratch_next.sh (plan.md), after the zero-shot trials and whole explorations.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/steps.sh
RUN1=/work/runs/scratch_office
RUN2=/work/runs/scratch_sparse
DATA=/work/runs/data_scratch
keep_run() {  # keep_run RUN NAME: the run's actors (keep_actors.py), config and scalars into scratch_run/NAME,
  # at once after training: /work/runs is lost with its machine (session 37's run was, before its evaluation)
  local run=$1 out=$HERE/scratch_run/$2
  $STEPS_PY $HERE/keep_actors.py $run/checkpoints $out > /dev/null
  cp $run/config.yaml $out/ 2>/dev/null || cp $run/.hydra/config.yaml $out/ 2>/dev/null || true
  cp $run/logs/a2c/scalars/*.csv $out/ 2>/dev/null || echo "== no scalars under $run/logs/a2c/scalars"
  echo "== kept $run in $out"
}
date; uptime
(
_frozen /work/train_code32 $STEPS_CODE32
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
keep_run $RUN1 office
keep_run $RUN2 sparse
echo "== training done"
ACTOR=$RUN2/checkpoints/last.pt
heldout_test $ACTOR /work/runs/test36
date; uptime
echo "== done"
