#!/usr/bin/env bash
# Session 76 (plan.md, step 2): named200_s76.sh's EM trials kept and read for their spread only.
#   runs/named200_em/{0_street,1_garage}/trials.jsonl  every finished chunk's trials of the scene (seeds 50-...)
#   partial/stop85_named200_em/SCENE_seeds_FIRST/0_SCENE/{config.yaml,trials.partial.jsonl}  an unfinished chunk,
#                                                  for a new machine to resume (cp -r it to /work/runs, rerun the driver)
#   em_named200_spread.log, targets_em_named200_spread  EM's new seeds against its stored seeds 0-49 of
#                                                  runs/street_garage50 (study_zero_shot.py --policy em
#                                                  --reference-policy em): the spread of EM's own mean, a planning
#                                                  figure, not a result
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
SRC=${SRC:-/work/runs/stop85_named200_em}
rm -rf $HERE/runs/named200_em $HERE/partial/stop85_named200_em  # kept again from SRC
for pair in 0_street:street 1_garage:garage; do
  folder=${pair%%:*}; scene=${pair##*:}
  mkdir -p $HERE/runs/named200_em/$folder
  cat $SRC/${scene}_seeds_*/0_$scene/trials.jsonl > $HERE/runs/named200_em/$folder/trials.jsonl 2>/dev/null || true
  [ -s $HERE/runs/named200_em/$folder/trials.jsonl ] || rm -r $HERE/runs/named200_em/$folder
  for chunk in $SRC/${scene}_seeds_*/0_$scene; do
    [ -e $chunk/trials.partial.jsonl ] && [ ! -e $chunk/trials.jsonl ] || continue
    kept=$HERE/partial/stop85_named200_em/$(basename $(dirname $chunk))/0_$scene
    mkdir -p $kept && cp $chunk/config.yaml $chunk/trials.partial.jsonl $kept/
  done
done
[ -d $HERE/runs/named200_em ] || { echo "no finished chunk in $SRC" >&2; exit 2; }
$PY $RESULTS/../study_zero_shot.py $HERE/runs/named200_em --reference $HERE/runs/street_garage50 --policy em \
  --reference-policy em --out $HERE/targets_em_named200_spread > $HERE/em_named200_spread.log
