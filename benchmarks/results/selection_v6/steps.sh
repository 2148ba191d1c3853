#!/usr/bin/env bash
# The steps the selection_v6 run records repeat, as one set of functions (source this file). Each is the exact
# command sequence of the scripts before it (em_choice_long.sh, val_em_choice_more.sh, study_em_choice_long.sh,
# test_em_choice_long.sh), which stay as the records of what ran. Frozen code: the 10-decision validation and the
# held-out test run on the session-32 code (their cached baselines were made there), whole explorations on the
# session-34 code (EM's and the default's trials were). Each function sets its own PYTHONPATH in a subshell.
STEPS_HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
STEPS_PY=/work/main/.venv/bin/python
# The frozen code, as git worktrees of this repository (made where missing, e.g. on a new machine):
# session-32 start (14db3d3; explore_rl/ and conf/ as f72406b) and session-34 main (21e9525).
STEPS_CODE32=14db3d3
STEPS_CODE34=21e9525
_frozen() {  # _frozen DIR COMMIT: cd into the frozen code at DIR (a worktree of COMMIT) with it on PYTHONPATH
  [ -e $1/explore_rl ] || git -C $STEPS_HERE worktree add --detach $1 $2 > /dev/null
  cd $1 && export PYTHONPATH=$1
}
# Session 38's 2-hour actor (scratch_em_choice.sh): the run's own file where it ran, else the copy keep_actors.py
# kept in the repository (same weights)
SCRATCH_ACTOR=/work/runs/scratch_sparse/checkpoints/last.pt
[ -e $SCRATCH_ACTOR ] || SCRATCH_ACTOR=$STEPS_HERE/scratch_run/sparse/last.pt
SPARSE_LOTS="scene.building.lot_probability=1 scene.building.size_min=28.0 scene.building.size_max=35.0 scene.building.lot_lane_width=[6.5,7.0] scene.building.lot_car_pitch=[6.0,6.5] scene.building.lot_gap_probability=0.5"

_cached() {  # _cached EPISODES DIR: the baseline episodes (EM, random, nearest; keyed by code, config and policy)
  # from this machine's cache, else from the copy kept in the repository (caches/, see keep_caches), else none:
  # the protocol then plays the baselines again (they are seeded: the same episodes, slower)
  local kept=$STEPS_HERE/caches/${1#/work/runs/}
  if [ -e $1 ]; then cp $1 $2/
  elif [ -e $kept ]; then cp $kept $2/ && echo "== baselines from $kept"
  else echo "== no cached baselines at $1: played again"; fi
}

keep_caches() {  # keep_caches NAME TESTDIR: keep the episode caches that NAME's validation and the test in TESTDIR
  # played, in the repository (caches/, small JSON lines), where _cached finds them on a machine without them
  local name=$1 test=$2 kind
  for kind in office building lots sparse; do
    mkdir -p $STEPS_HERE/caches/val/$kind/dagger_sparse_last
    cp /work/runs/val/$kind/$name/episodes.jsonl $STEPS_HERE/caches/val/$kind/dagger_sparse_last/
  done
  for kind in office building; do
    mkdir -p $STEPS_HERE/caches/test33/$kind
    cp $test/$kind/episodes.jsonl $STEPS_HERE/caches/test33/$kind/
  done
}

validate_10() {  # validate_10 ACTOR NAME: 10-decision validation on office, buildings, lots, sparse lots
  local actor=$1 name=$2
  (
    _frozen /work/train_code32 $STEPS_CODE32
    local py="nice -n 5 $STEPS_PY benchmarks/study_learning.py --policy $actor"
    local office="--layouts 1000 1001 1002 1003 1004 1005 1006 1007 1008 1009 --starts 3 --max-decisions 10 --workers 2 --set graph.features=extended"
    local build="--scene building --layouts 1000 1001 1002 1003 1004 --starts 4 --max-decisions 10 --workers 2 --set graph.features=extended"
    local args out
    for kind in office building lots sparse; do
      out=/work/runs/val/$kind/$name
      mkdir -p $out && _cached /work/runs/val/$kind/dagger_sparse_last/episodes.jsonl $out
      case $kind in
        office) args=$office ;;
        building) args=$build ;;
        lots) args="$build scene.building.lot_probability=1" ;;
        sparse) args="$build $SPARSE_LOTS" ;;
      esac
      echo "== $name $kind"
      $py $args --out $out
    done
  )
}

heldout_test() {  # heldout_test ACTOR DIR: the held-out 10-decision test (test33's cached episodes), once
  local actor=$1 dir=$2
  (
    _frozen /work/train_code32 $STEPS_CODE32
    local py="nice -n 5 $STEPS_PY benchmarks/study_learning.py --policy $actor --max-decisions 10 --workers 2 --set graph.features=extended"
    for kind in office building; do mkdir -p $dir/$kind && _cached /work/runs/test33/$kind/episodes.jsonl $dir/$kind; done
    echo "== test office"
    $py --layouts 2000 2001 --starts 9 --out $dir/office
    echo "== test building"
    $py --scene building --layouts 2000 2001 2002 2003 2004 --starts 4 --out $dir/building
  )
}

whole_two_trials() {  # whole_two_trials ACTOR NAME: whole explorations of the 20 validation scenes, seeds 0 and 1
  local actor=$1 name=$2
  (
    _frozen /work/train_code34 $STEPS_CODE34
    local eval="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
    local seeds=scene.seed=1000,1001,1002,1003,1004,1005,1006,1007,1008,1009
    local common
    for seed in 0 1; do
      common="slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 evaluate.progress_bar=false seed=$seed"
      $eval -m scene=building $seeds $common "evaluate.policies=[learned]" policy.checkpoint=$actor \
        out=/work/runs/val_whole/buildings_${name}_seed$seed
      $eval -m scene=building $seeds $common $SPARSE_LOTS "evaluate.policies=[learned]" policy.checkpoint=$actor \
        out=/work/runs/val_whole/sparse_${name}_seed$seed
    done
  )
}

keep_whole() {  # keep_whole NAME: copy the trials and summaries of whole_two_trials into runs/
  local name=$1 src dst
  for kind in buildings sparse; do
    for seed in 0 1; do
      src=/work/runs/val_whole/${kind}_${name}_seed$seed dst=$STEPS_HERE/runs/${kind}_${name}_seed$seed
      rm -rf $dst && mkdir -p $dst && cp $src/summary.md $dst/
      for d in $src/*_building_*; do mkdir -p $dst/$(basename $d) && cp $d/trials.jsonl $d/summary.md $dst/$(basename $d)/; done
    done
  done
}

_pooled_folder() {  # _pooled_folder OUT SEED0 SEED1: one folder linking both trials of every scene
  mkdir -p $1
  for f in $2/*_building_*; do ln -s $f $1/seed0_$(basename $f); done
  for f in $3/*_building_*; do ln -s $f $1/seed1_$(basename $f); done
}

pool_whole() {  # pool_whole NAME OTHER LABEL: NAME's two trials per scene against EM's (the rule's figure,
  # targets_NAME_2trials) and against OTHER's two (a kept learned run, direct_NAME_vs_LABEL)
  local name=$1 other=$2 label=$3 runs=$STEPS_HERE/runs tmp
  tmp=$(mktemp -d)
  for kind in buildings sparse; do
    _pooled_folder $tmp/${kind}_cand $runs/${kind}_${name}_seed0 $runs/${kind}_${name}_seed1
    _pooled_folder $tmp/${kind}_em $runs/${kind}_em $runs/${kind}_em_seed1
    _pooled_folder $tmp/${kind}_other $runs/${kind}_${other}_seed0 $runs/${kind}_${other}_seed1
  done
  (
    unset PYTHONPATH
    local study=$STEPS_HERE/../../study_zero_shot.py
    $STEPS_PY $study $tmp/buildings_cand $tmp/sparse_cand --reference $tmp/buildings_em $tmp/sparse_em \
      --pool val_whole_${name}_2trials --out $STEPS_HERE/targets_${name}_2trials > $STEPS_HERE/study_${name}_2trials.log
    $STEPS_PY $study $tmp/buildings_cand $tmp/sparse_cand --reference $tmp/buildings_other $tmp/sparse_other \
      --reference-policy learned --pool ${name}_vs_${label}_2trials --out $STEPS_HERE/direct_${name}_vs_$label \
      > $STEPS_HERE/direct_${name}_vs_$label.log
  )
  rm -r $tmp
}

zero_shot_trials() {  # zero_shot_trials ACTOR DIR: street and garage 20 trials, 20 held-out buildings (learned only)
  local actor=$1 dir=$2
  (
    _frozen /work/train_code32 $STEPS_CODE32
    local eval="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
    local common="graph.max_nodes=1024 evaluate.progress_bar=false evaluate.policies=[learned] policy.checkpoint=$actor"
    $eval -m scene=street,garage evaluate.trials=10 $common out=$dir/street_garage_a
    $eval -m scene=street,garage seed=10 scene.seed=0 evaluate.trials=10 $common out=$dir/street_garage_b
    $eval -m scene=building scene.seed=2000,2001,2002,2003,2004,2005,2006,2007,2008,2009,2010,2011,2012,2013,2014,2015,2016,2017,2018,2019 \
      slam=icp evaluate.trials=1 explore.travel_budget=250 $common out=$dir/buildings
  )
}

zero_shot_study() {  # zero_shot_study DIR NAME: keep DIR's trials in zero_shot_runs_NAME/ and pool them against EM's
  # seeded trials of zero_shot_v5_20 (zero_shot_NAME.log) and against the shipped policy's (..._vs_shipped.log)
  local dir=$1 name=$2 keep=$STEPS_HERE/zero_shot_runs_$2 v5=$STEPS_HERE/../zero_shot_v5_20 dst
  local shipped=$STEPS_HERE/zero_shot_runs
  rm -rf $keep && mkdir -p $keep/street_garage $keep/buildings
  for part in a b; do
    for d in $dir/street_garage_$part/*_*; do
      [ -d $d ] || continue
      dst=$keep/street_garage/$(basename $d)_$part && mkdir -p $dst && cp $d/trials.jsonl $d/summary.md $dst/
    done
  done
  for d in $dir/buildings/*_building_*; do
    dst=$keep/buildings/$(basename $d) && mkdir -p $dst && cp $d/trials.jsonl $d/summary.md $dst/
  done
  (
    unset PYTHONPATH
    local study=$STEPS_HERE/../../study_zero_shot.py
    $STEPS_PY $study $keep/street_garage $keep/buildings --reference $v5/street_garage $v5/buildings \
      --out $STEPS_HERE/zero_shot_$name > $STEPS_HERE/zero_shot_$name.log
    $STEPS_PY $study $keep/street_garage $keep/buildings --reference $shipped/street_garage $shipped/buildings \
      --reference-policy learned --out $STEPS_HERE/zero_shot_${name}_vs_shipped > $STEPS_HERE/zero_shot_${name}_vs_shipped.log
  )
}
