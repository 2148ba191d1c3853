#!/usr/bin/env bash
# plan.md: keep run.sh's finished buildings in runs/SET (val: /work/runs/stop85_val, test: /work/runs/stop85_test,
# prior_val: the loop prior's trials with EM's of runs/val; SETS="test": only those sets, the others' logs kept),
# then study_zero_shot.py (the learned trials against EM's of the same run, paired by building):
#   study_SET.log / targets_SET                  every finished building, compared at the common coverage
#   reached_SET.log                              how many buildings each policy brought to 85 %
#   study_SET_reached.log / targets_SET_reached  only the buildings both policies brought to 85 %
#   by_coverage_SET.log                          the pooled ratios at 40-85 % explored (by_coverage.py)
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
STUDY="$PY $RESULTS/../study_zero_shot.py"
# the loop prior's learned-only trials (plan.md's addendum), each building joined with EM's trial of runs/val
for d in /work/runs/stop85_prior_val/building_*/; do
  [ -e $d/trials.jsonl ] || continue
  b=$(basename $d); mkdir -p $HERE/runs/prior_val/$b
  cat $d/trials.jsonl > $HERE/runs/prior_val/$b/trials.jsonl
  grep '"policy": "em"' $HERE/runs/val/$b/trials.jsonl >> $HERE/runs/prior_val/$b/trials.jsonl
  cp $d/summary.md $HERE/runs/prior_val/$b/
done
for SET in ${SETS:-val test prior_val}; do
  [ $SET = prior_val ] || keep /work/runs/stop85_$SET $HERE/runs/$SET  # prior_val: joined above
  [ -d $HERE/runs/$SET ] || continue  # not run (yet)
  $STUDY $HERE/runs/$SET --pool $SET --out $HERE/targets_$SET > $HERE/study_$SET.log
  $PY $HERE/by_coverage.py $HERE/runs/$SET --coverages 0.4 0.5 0.6 0.7 0.8 0.85 > $HERE/by_coverage_$SET.log
  rm -rf $HERE/runs/${SET}_reached
  $PY $HERE/reached.py $HERE/runs/$SET --out $HERE/runs/${SET}_reached > $HERE/reached_$SET.log
  [ -d $HERE/runs/${SET}_reached ] || continue
  $STUDY $HERE/runs/${SET}_reached --pool ${SET}_reached --out $HERE/targets_${SET}_reached > $HERE/study_${SET}_reached.log
done
