#!/usr/bin/env bash
# plan.md: keep run.sh's finished buildings in runs/SET (val, val2, test: /work/runs/stop85_SET;
# prior[_B]_val, prior_B_test, prior_X_val90, session 55's nodesN_val90 / nodesN_test, daggerN_val/_val90/_test and
# session 65's icpN_val90: a learned-only variant's trials of /work/runs/stop85_SET (a prior, another graph.max_nodes
# or a fine-tuned actor),
# each building joined with EM's trial of runs/val, val2 or test; SETS="test": only those sets, the others' logs kept), then
# study_zero_shot.py (the learned trials against EM's, paired by building):
#   study_SET.log / targets_SET                  every finished building, compared at the common coverage
#   reached_SET.log                              how many buildings each policy brought to 85 %
#   study_SET_reached.log / targets_SET_reached  only the buildings both policies brought to 85 %
#   by_coverage_SET.log                          the pooled ratios at 40-85 % explored (by_coverage.py)
#   phases_SET.log                               how each policy explores per coverage band (phases.py)
# and, once val2 has buildings, the 90-building validation pool 1010-1099 (runs/val and runs/val2): study_val90.log,
# by_coverage_val90.log, phases_val90.log (plan.md, session 52 step C).
# Session 61's held-out pool 2020-2219: runs/test2 (EM on 2120-2219, /work/runs/stop85_test2), a variant's trials there
# (SET_test2, joined with runs/test2's EM like the _test sets) and SETS="X_test200": runs/X_test and runs/X_test2 pooled
# against EM (study_X_test200.log, by_coverage_X_test200.log).
# Session 63's fresh held-out pool 2220-2419: runs/test3 (EM, /work/runs/stop85_test3) and a variant's X_test3 (joined
# with runs/test3's EM like the _test2 sets; one set of 200 buildings, no halves); SETS="X_test400": runs/X_test,
# X_test2 and X_test3 pooled against EM (2020-2419; descriptive, study_X_test400.log, by_coverage_X_test400.log).
# Session 65's next fresh pool 2420-2619: runs/test4 (EM, /work/runs/stop85_test4) and a variant's X_test4 (joined with
# runs/test4's EM like the _test3 sets), for the next candidate chosen on validation. Session 71's pool 2620-2819:
# runs/test5 (EM, /work/runs/stop85_test5) and X_test5 the same way; session 74's pool 2820-3019: runs/test6 and X_test6.
# Street and garage (street_garage.sh, /work/runs/stop85_street_garage): study_street_garage.log, targets_street_garage.
# Session 69's garage-like validation pool lots_val (lots_s69.sh: sparse-lot buildings, EM and the default in one run).
# Session 70's garage-like lots glots_val (plan.md session 70 step 2b): the default's trials of
# /work/runs/stop85_glots_learned joined with EM's of /work/runs/stop85_glots_em, building by building; glotsX_val:
# a configuration's trials of /work/runs/stop85_glotsX_learned (step 4) joined the same way; glots_rep: the default's
# replication on 1080-1109 (step 5, not pooled with glots_val); glots_em: EM's trials of every garage-like lot, kept in
# runs/glots_em (the EM side of those sets, so they can be re-joined on a new machine). Session 71: glotsX_val90, the
# trials of /work/runs/stop85_glotsX_learned on all 90 lots 1050-1139 (glots_val90: the default's).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
STUDY="$PY $RESULTS/../study_zero_shot.py"
COVERAGES="0.4 0.5 0.6 0.7 0.8 0.85"
# join_prior SET: the loop prior's learned-only trials of /work/runs/stop85_SET (plan.md's addenda), each building
# joined with EM's trial of runs/val, runs/val2 or runs/test (the same config; SET ..._val90: val and val2)
join_prior() {
  case $1 in *_val90) em_sets="val val2";; *) em_sets=${1##*_};; esac
  for d in /work/runs/stop85_$1/building_*/; do
    [ -e $d/trials.jsonl ] || continue
    b=$(basename $d)
    for em in $em_sets; do
      if [ -e $HERE/runs/$em/$b/trials.jsonl ]; then  # a building EM has not finished is left out
        mkdir -p $HERE/runs/$1/$b && cp $d/summary.md $HERE/runs/$1/$b/
        cat $d/trials.jsonl > $HERE/runs/$1/$b/trials.jsonl
        grep '"policy": "em"' $HERE/runs/$em/$b/trials.jsonl >> $HERE/runs/$1/$b/trials.jsonl
      fi
    done
  done
}
# keep_lots_em: EM's trials of every garage-like lot (/work/runs/stop85_glots_em) kept in runs/glots_em; on a new
# machine the kept ones stay
keep_lots_em() { keep /work/runs/stop85_glots_em $HERE/runs/glots_em; }
# join_lots SET KIND FIRST LAST: a policy's trials of /work/runs/stop85_KIND_learned on buildings FIRST-LAST joined
# with EM's of runs/glots_em, each building both finished (session 70's garage-like lots: glots_val for the shipped
# default on 1050-1079, glotsX_val for a configuration X of it there (REFS=glots_val bash direct.sh glotsX_val pairs
# the two), glots_rep for the default's replication on 1080-1109)
join_lots() {
  local em=$HERE/runs/glots_em
  keep_lots_em
  for seed in $(seq $3 $4); do
    local d=/work/runs/stop85_$2_learned/building_$seed
    [ -e $d/trials.jsonl ] && [ -e $em/building_$seed/trials.jsonl ] || continue
    mkdir -p $HERE/runs/$1/building_$seed && cp $d/summary.md $HERE/runs/$1/building_$seed/
    cat $d/trials.jsonl $em/building_$seed/trials.jsonl > $HERE/runs/$1/building_$seed/trials.jsonl
  done
}
# street_garage: street_garage.sh's scenes (one folder each, 10 trials per policy), EM and the learned policy compared
# trial by trial (study_street_garage.log); with the baselines' run (step D) one table of all four policies
# (runs/street_garage/summary.md, by explore_rl.comparison.combine)
street_garage() {
  for scene in /work/runs/stop85_street_garage/*/; do
    [ -e $scene/trials.jsonl ] || continue  # not finished (yet)
    name=$(basename $scene); mkdir -p $HERE/runs/street_garage/$name
    cat $scene/trials.jsonl /work/runs/stop85_street_garage_baselines/$name/trials.jsonl 2>/dev/null \
      > $HERE/runs/street_garage/$name/trials.jsonl || true
    cp $scene/summary.md $HERE/runs/street_garage/$name/
  done
  [ -d $HERE/runs/street_garage ] || return 0
  $STUDY $HERE/runs/street_garage --out $HERE/targets_street_garage > $HERE/study_street_garage.log
  $PY -c "from explore_rl.comparison import combine; combine('$HERE/runs/street_garage')"
}
# street_garage_variant SET: another actor's learned-only trials of /work/runs/stop85_SET (street_garage.sh with
# EXTRA, session 58), each scene joined with EM's, nearest frontier's and random's trials of runs/street_garage (the
# same seeds and config): runs/SET/summary.md (all four policies), study_SET.log against EM, and
# direct_SET.log against the shipped default's trials there (paired trial by trial, --reference-policy learned)
street_garage_variant() {
  for scene in /work/runs/stop85_$1/*/; do
    [ -e $scene/trials.jsonl ] || continue
    name=$(basename $scene); mkdir -p $HERE/runs/$1/$name
    cp $scene/summary.md $HERE/runs/$1/$name/
    cat $scene/trials.jsonl > $HERE/runs/$1/$name/trials.jsonl
    grep -v '"policy": "learned"' $HERE/runs/street_garage/$name/trials.jsonl >> $HERE/runs/$1/$name/trials.jsonl
  done
  [ -d $HERE/runs/$1 ] || return 0
  $STUDY $HERE/runs/$1 --out $HERE/targets_$1 > $HERE/study_$1.log
  $PY -c "from explore_rl.comparison import combine; combine('$HERE/runs/$1')"  # the four-policy table and plots
  $STUDY $HERE/runs/$1 --reference $HERE/runs/street_garage --reference-policy learned --out $HERE/targets_$1_direct \
    > $HERE/direct_$1.log
}
# street_garage50 (session 67): the shipped default and EM in the street and the garage at 50 trials per policy: seeds
# 0-9 from the stored runs (the default's of runs/street_garage_dagger9k, EM's of runs/street_garage) and seeds 10-49
# from street_garage50_s67.sh's chunks (/work/runs/stop85_street_garage50/seeds_*; their seeds 8-9 repeat stored
# trials and are left out here): runs/street_garage50, study_street_garage50.log (descriptive, plan.md session 67)
street_garage50() {
  local chunks=/work/runs/stop85_street_garage50
  for name in 0_street 1_garage; do
    ls $chunks/seeds_*/$name/trials.jsonl > /dev/null 2>&1 || continue  # no chunk finished (yet)
    mkdir -p $HERE/runs/street_garage50/$name
    { grep '"policy": "learned"' $HERE/runs/street_garage_dagger9k/$name/trials.jsonl
      grep '"policy": "em"' $HERE/runs/street_garage/$name/trials.jsonl
      $PY -c 'import json, sys; [print(line, end="") for path in sys.argv[1:] for line in open(path)
               if json.loads(line)["seed"] >= 10]' $chunks/seeds_*/$name/trials.jsonl
    } > $HERE/runs/street_garage50/$name/trials.jsonl
  done
  [ -d $HERE/runs/street_garage50 ] || return 0
  $STUDY $HERE/runs/street_garage50 --out $HERE/targets_street_garage50 > $HERE/study_street_garage50.log
}
# street_garage50_variant NAME (session 69): another configuration's learned-only trials of
# /work/runs/stop85_street_garage_NAME (street_garage.sh with SEED=0 TRIALS=50 and EXTRA; SCENES=garage: one scene), each scene joined with EM's
# 50 trials of runs/street_garage50 (seeds 0-49, the same config): runs/street_garage50_NAME, study_street_garage50_NAME.log
# against EM, direct_street_garage50_NAME.log against the shipped default's 50 trials there (paired trial by trial),
# and study_street_garage50_NAME_first10.log: seeds 0-9 alone (the issue's count; descriptive)
street_garage50_variant() {
  local set=street_garage50_$1
  for name in 0_street 1_garage; do
    # the run's folder of this scene: N_street / N_garage (N is the sweep's job number: 0 when one scene ran alone)
    local src=$(ls -d /work/runs/stop85_street_garage_$1/*_${name#*_} 2>/dev/null | head -1)
    [ -n "$src" ] && [ -e $src/trials.jsonl ] || continue
    mkdir -p $HERE/runs/$set/$name $HERE/runs/${set}_first10/$name
    { cat $src/trials.jsonl
      grep '"policy": "em"' $HERE/runs/street_garage50/$name/trials.jsonl
    } > $HERE/runs/$set/$name/trials.jsonl
    $PY -c 'import json, sys; [print(line, end="") for line in open(sys.argv[1]) if json.loads(line)["seed"] < 10]' \
      $HERE/runs/$set/$name/trials.jsonl > $HERE/runs/${set}_first10/$name/trials.jsonl
  done
  [ -d $HERE/runs/$set ] || return 0
  $STUDY $HERE/runs/$set --out $HERE/targets_$set > $HERE/study_$set.log
  $STUDY $HERE/runs/${set}_first10 --out $HERE/targets_${set}_first10 > $HERE/study_${set}_first10.log
  $STUDY $HERE/runs/$set --reference $HERE/runs/street_garage50 --reference-policy learned --out $HERE/targets_${set}_direct \
    > $HERE/direct_$set.log
}
# street_garage200_variant NAME (session 76, plan.md's addendum of 07:17 UTC): a candidate's learned-only trials of
# /work/runs/stop85_street_garage_NAME (street_garage.sh with SEED=0 TRIALS=120 and EXTRA) joined, scene by scene,
# with EM's 200 trials there: seeds 0-49 of runs/street_garage50 and 50-199 of runs/named200_em
# (named200_keep_s76.sh). A scene is read only when EM's 200 trials and the candidate's 120 are all there:
# runs/street_garage200_NAME, study_street_garage200_NAME.log
street_garage200_variant() {
  local set=street_garage200_$1 name src em mine
  for name in 0_street 1_garage; do
    src=$(ls -d /work/runs/stop85_street_garage_$1/*_${name#*_} 2>/dev/null | head -1)
    [ -n "$src" ] && [ -e $src/trials.jsonl ] || continue
    em=$(cat $HERE/runs/street_garage50/$name/trials.jsonl $HERE/runs/named200_em/$name/trials.jsonl 2>/dev/null \
      | grep -c '"policy": "em"' || true)
    mine=$(grep -c '"policy": "learned"' $src/trials.jsonl || true)
    if [ $em -lt 200 ] || [ $mine -lt 120 ]; then
      echo "$set $name: EM has $em of its 200 trials and the candidate $mine of its 120; not read" >&2; continue
    fi
    mkdir -p $HERE/runs/$set/$name
    { grep '"policy": "learned"' $src/trials.jsonl
      grep '"policy": "em"' $HERE/runs/street_garage50/$name/trials.jsonl
      cat $HERE/runs/named200_em/$name/trials.jsonl
    } > $HERE/runs/$set/$name/trials.jsonl
  done
  [ -d $HERE/runs/$set ] || return 0
  $STUDY $HERE/runs/$set --out $HERE/targets_$set > $HERE/study_$set.log
}
# baselines_test: nearest frontier's and random's trials of /work/runs/stop85_baselines_test (ship_s58.sh baselines,
# session 58) with EM's of runs/test and the shipped default's of runs/dagger9k_test, building by building:
# runs/baselines_test/summary.md, one table of all four policies (explore_rl.comparison.combine)
baselines_test() {
  for d in /work/runs/stop85_baselines_test/building_*/; do
    [ -e $d/trials.jsonl ] || continue
    b=$(basename $d)
    [ -e $HERE/runs/dagger9k_test/$b/trials.jsonl ] || continue
    mkdir -p $HERE/runs/baselines_test/$b
    cat $HERE/runs/dagger9k_test/$b/trials.jsonl $d/trials.jsonl > $HERE/runs/baselines_test/$b/trials.jsonl
  done
  [ -d $HERE/runs/baselines_test ] || return 0
  $PY -c "from explore_rl.comparison import combine; combine('$HERE/runs/baselines_test')"
}
# held_out_pooled X NAME SUFFIXES: the variant X's trials on several held-out pools, pooled against EM
# (study_X_NAME.log, by_coverage_X_NAME.log): X_test200 = runs/X_test + runs/X_test2 (2020-2219, session 61's judged
# pool); X_test400 = those and runs/X_test3 (2020-2419; descriptive only, plan.md's session 63 addendum)
held_out_pooled() {
  local dirs=""
  for suffix in $3; do
    [ -d $HERE/runs/${1}_$suffix ] || { echo "runs/${1}_$suffix: not there; run SETS=\"${1}_$suffix\" study.sh first" >&2; return 0; }
    dirs="$dirs $HERE/runs/${1}_$suffix"
  done
  $STUDY $dirs --pool ${1}_$2 --out $HERE/targets_${1}_$2 > $HERE/study_${1}_$2.log
  $PY $HERE/by_coverage.py $dirs --coverages $COVERAGES > $HERE/by_coverage_${1}_$2.log
}
PRIORS=$(cd /work/runs && ls -d stop85_prior*_val stop85_prior*_val90 stop85_prior*_test stop85_prior*_test2 stop85_prior*_test3 stop85_nodes*_val90 stop85_nodes*_test stop85_dagger*_val stop85_dagger*_val90 stop85_dagger*_test stop85_dagger*_test2 stop85_dagger*_test3 stop85_*_test4 stop85_*_test5 stop85_*_test6 stop85_blind*_val90 stop85_gate*_val stop85_icp*_val90 stop85_street_garage_?* stop85_baselines_test 2>/dev/null | sed 's/^stop85_//' || true)
for SET in ${SETS:-val val2 test test2 test3 $PRIORS street_garage}; do
  case $SET in
    *_test200) held_out_pooled ${SET%_test200} test200 "test test2"; continue;;
    *_test400) held_out_pooled ${SET%_test400} test400 "test test2 test3"; continue;;
    test2|test3|test4|test5|test6) keep /work/runs/stop85_$SET $HERE/runs/$SET; continue;;  # EM's trials alone: the variants' reference
    street_garage) street_garage; continue;;
    street_garage50) street_garage50; continue;;
    street_garage50_*) street_garage50_variant ${SET#street_garage50_}; continue;;
    street_garage200_*) street_garage200_variant ${SET#street_garage200_}; continue;;
    street_garage_late150) continue;;  # 50 trials: the set street_garage50_late150 studies it
    street_garage_prior004) continue;;  # 50 garage trials (session 70): the set street_garage50_prior004 studies it
    street_garage_baselines) continue;;
    baselines_test) baselines_test; continue;;  # step D's nearest and random: part of street_garage's table
    street_garage_*) street_garage_variant $SET; continue;;
    prior*|nodes*|dagger*|blind*|gate*|icp*) join_prior $SET;;
    glots_rep) join_lots $SET glots 1080 1109;;
    glots_em) keep_lots_em; continue;;
    glots*_val) join_lots $SET ${SET%_val} 1050 1079;;
    glots*_val90) join_lots $SET ${SET%_val90} 1050 1139;;
    val|val2|test|lots_val) keep /work/runs/stop85_$SET $HERE/runs/$SET;;  # EM's and the default's trials of one run
    *) echo "SETS: '$SET' is no set study.sh knows; a learned-only variant's name starts with prior, nodes, dagger," \
         "blind, gate or icp (its trials are joined with EM's)" >&2; exit 2;;
  esac
  [ -d $HERE/runs/$SET ] || continue  # not run (yet)
  $STUDY $HERE/runs/$SET --pool $SET --out $HERE/targets_$SET > $HERE/study_$SET.log
  $PY $HERE/by_coverage.py $HERE/runs/$SET --coverages $COVERAGES > $HERE/by_coverage_$SET.log
  $PY $HERE/phases.py $HERE/runs/$SET > $HERE/phases_$SET.log
  rm -rf $HERE/runs/${SET}_reached
  $PY $HERE/reached.py $HERE/runs/$SET --out $HERE/runs/${SET}_reached > $HERE/reached_$SET.log
  [ -d $HERE/runs/${SET}_reached ] || continue
  $STUDY $HERE/runs/${SET}_reached --pool ${SET}_reached --out $HERE/targets_${SET}_reached > $HERE/study_${SET}_reached.log
done
if [ -z "$SETS" ] && [ -d $HERE/runs/val2 ]; then
  $STUDY $HERE/runs/val $HERE/runs/val2 --pool val90 --out $HERE/targets_val90 > $HERE/study_val90.log
  $PY $HERE/by_coverage.py $HERE/runs/val $HERE/runs/val2 --coverages $COVERAGES > $HERE/by_coverage_val90.log
  $PY $HERE/phases.py $HERE/runs/val $HERE/runs/val2 > $HERE/phases_val90.log
fi
