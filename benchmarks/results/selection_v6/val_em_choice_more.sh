#!/usr/bin/env bash
# plan.md (session 35, exploratory, for session 36): after em_choice_more.sh, its 10-decision validation and its
# whole explorations on the 20 validation scenes with two trials per scene, as em_choice_long's, then the pooled
# figures against EM (the rule's) and against the shipped policy (em_choice_long). Nothing is shipped from it.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
while pgrep -f "\./em_choice_more\.sh" > /dev/null; do sleep 20; done
ACTOR=/work/runs/em_choice_more/checkpoints/last.pt
cd /work/train_code32
export PYTHONPATH=/work/train_code32
PY="nice -n 5 /work/main/.venv/bin/python benchmarks/study_learning.py --policy $ACTOR"
OFFICE="--layouts 1000 1001 1002 1003 1004 1005 1006 1007 1008 1009 --starts 3 --max-decisions 10 --workers 2 --set graph.features=extended"
BUILD="--scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --workers 2 --set graph.features=extended"
LOTS="$BUILD scene.building.lot_probability=1"
SPARSE="$LOTS scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
for kind in office building lots sparse; do
  out=/work/runs/val/$kind/em_choice_more_s35
  mkdir -p $out
  cp /work/runs/val/$kind/dagger_sparse_last/episodes.jsonl $out/
  args=$OFFICE; [ $kind = building ] && args=$BUILD; [ $kind = lots ] && args=$LOTS; [ $kind = sparse ] && args=$SPARSE
  echo "== em_choice_more $kind"
  $PY $args --out $out
done
cd /work/train_code34
export PYTHONPATH=/work/train_code34
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
SEEDS=scene.seed=1000,1001,1002,1003,1004,1005,1006,1007,1008,1009
SPARSE="scene.building.lot_probability=1 scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"
for seed in 0 1; do
  COMMON="slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 evaluate.progress_bar=false seed=$seed"
  $EVAL -m scene=building $SEEDS $COMMON "evaluate.policies=[learned]" policy.checkpoint=$ACTOR out=/work/runs/val_whole/buildings_em_choice_more_seed$seed
  $EVAL -m scene=building $SEEDS $COMMON $SPARSE "evaluate.policies=[learned]" policy.checkpoint=$ACTOR out=/work/runs/val_whole/sparse_em_choice_more_seed$seed
done
cd $HERE
unset PYTHONPATH
PY=/work/main/.venv/bin/python
STUDY=$HERE/../../study_zero_shot.py
for kind in buildings sparse; do
  for seed in 0 1; do
    src=/work/runs/val_whole/${kind}_em_choice_more_seed$seed dst=$HERE/runs/${kind}_em_choice_more_seed$seed
    rm -rf $dst && mkdir -p $dst && cp $src/summary.md $dst/
    for d in $src/*_building_*; do mkdir -p $dst/$(basename $d) && cp $d/trials.jsonl $d/summary.md $dst/$(basename $d)/; done
  done
done
T=$(mktemp -d)
link() {  # link NAME SEED0_FOLDER SEED1_FOLDER: one folder with both trials of every scene
  mkdir -p $T/$1
  for f in $2/*_building_*; do ln -s $f $T/$1/seed0_$(basename $f); done
  for f in $3/*_building_*; do ln -s $f $T/$1/seed1_$(basename $f); done
}
for kind in buildings sparse; do
  link ${kind}_cand $HERE/runs/${kind}_em_choice_more_seed0 $HERE/runs/${kind}_em_choice_more_seed1
  link ${kind}_em $HERE/runs/${kind}_em $HERE/runs/${kind}_em_seed1
  link ${kind}_shipped $HERE/runs/${kind}_em_choice_long_seed0 $HERE/runs/${kind}_em_choice_long_seed1
done
$PY $STUDY $T/buildings_cand $T/sparse_cand --reference $T/buildings_em $T/sparse_em \
  --pool val_whole_em_choice_more_2trials --out $HERE/targets_em_choice_more_2trials > $HERE/study_em_choice_more_2trials.log
$PY $STUDY $T/buildings_cand $T/sparse_cand --reference $T/buildings_shipped $T/sparse_shipped --reference-policy learned \
  --pool em_choice_more_vs_shipped_2trials --out $HERE/direct_em_choice_more_vs_shipped > $HERE/direct_em_choice_more_vs_shipped.log
rm -r $T
echo "== done"
