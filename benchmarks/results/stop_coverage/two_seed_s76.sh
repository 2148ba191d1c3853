#!/usr/bin/env bash
# Session 76 (plan.md, step 3; descriptive, selects nothing): every validation variant of the line figure
# (line_s75.sh) against EM's two trials of each of the 90 validation buildings 1010-1099: the stored first trials of
# runs/val and runs/val2 and session 75's second ones of runs/em_replicate_val90 (evaluate.first_trial=1), pooled as
# one reference per building (study_zero_shot.py resamples the two within each building). Each variant's learned
# trials only go into its report (its joined EM trial would be counted twice). Logs two_seed_NAME.log and
# targets_two_seed_NAME, then line.py's figure from those: line_two_seed.{png,csv,log} (the same two points draw the
# line as in line_s75.sh).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
WORK=$(mktemp -d)
trap 'rm -rf $WORK' EXIT

# em_two_seeds OUT: each building both EM runs finished, with both EM trials in one trials.jsonl
em_two_seeds() {
  local d b
  for d in $HERE/runs/em_replicate_val90/building_*/; do
    b=$(basename $d)
    for stored in val val2; do
      [ -e $HERE/runs/$stored/$b/trials.jsonl ] || continue
      mkdir -p $1/$b
      { grep '"policy": "em"' $HERE/runs/$stored/$b/trials.jsonl; grep '"policy": "em"' $d/trials.jsonl; } > $1/$b/trials.jsonl
    done
  done
}

# learned_only OUT SET...: the learned trials of runs/SET's buildings that have EM's two trials
learned_only() {
  local out=$1 set d b; shift
  for set in "$@"; do
    for d in $HERE/runs/$set/building_*/; do
      b=$(basename $d)
      [ -e $WORK/em2/$b/trials.jsonl ] || continue
      mkdir -p $out/$b && grep '"policy": "learned"' $d/trials.jsonl > $out/$b/trials.jsonl
    done
  done
}

# two_seed NAME SET...: NAME's learned trials (runs/SET...) against EM's two seeds
two_seed() {
  local name=$1; shift
  learned_only $WORK/$name "$@"
  $PY $RESULTS/../study_zero_shot.py $WORK/$name --reference $WORK/em2 --pool $name \
    --out $HERE/targets_two_seed_$name > $HERE/two_seed_$name.log
  echo "--point $name=targets_two_seed_$name/$name/targets.json"
}

em_two_seeds $WORK/em2
POINTS=""
POINTS+=" $(two_seed default val val2)"
POINTS+=" $(two_seed loop0.08_candidate prior_cand0.08_val90)"
POINTS+=" $(two_seed loop0.08_until150m prior_open150_val90)"
POINTS+=" $(two_seed loop0.08_until250m prior_open250_val90)"
POINTS+=" $(two_seed closure8.2 prior_closure_val90)"
POINTS+=" $(two_seed nodes512 nodes512_val90)"
POINTS+=" $(two_seed dagger9k dagger9k_val90)"
POINTS+=" $(two_seed blind9k blind9k_val90)"
POINTS+=" $(two_seed dagger9k_loop0.04 prior_dagger0.04_val90)"
POINTS+=" $(two_seed dagger9k_loop0.02 prior_dagger0.02_val90)"
POINTS+=" $(two_seed dagger9k_loop0.04_from150m prior_late150_val90)"
POINTS+=" $(two_seed dagger71_glots dagger71_val90)"
POINTS+=" $(two_seed dagger72_revisit3 dagger72_val90)"
POINTS+=" $(two_seed dagger74_lot dagger74_val90)"
cd $HERE
mkdir -p $WORK/line
$PY line.py --out $WORK/line $POINTS --line default loop0.08_candidate > line_two_seed.log
cp $WORK/line/line.png line_two_seed.png
cp $WORK/line/line.csv line_two_seed.csv
