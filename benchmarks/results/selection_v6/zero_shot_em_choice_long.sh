#!/usr/bin/env bash
# plan.md (session 35): em_choice_long's zero-shot trials (test_em_choice_long.sh: street and garage 20 trials,
# 20 held-out buildings; learned only) against EM's seeded trials of zero_shot_v5_20 (the same scenes and
# seeds, the same frozen code), and against the previous default's trials there. Trials and summaries are
# kept in zero_shot_runs/.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
PY=${PY:-/work/main/.venv/bin/python}
STUDY=$HERE/../../study_zero_shot.py
V5=$HERE/../zero_shot_v5_20
KEEP=$HERE/zero_shot_runs
rm -rf $KEEP && mkdir -p $KEEP/street_garage $KEEP/buildings
for part in a b; do
  for d in /work/runs/zs35/street_garage_$part/*_*; do
    [ -d $d ] || continue
    dst=$KEEP/street_garage/$(basename $d)_$part && mkdir -p $dst && cp $d/trials.jsonl $d/summary.md $dst/
  done
done
for d in /work/runs/zs35/buildings/*_building_*; do
  dst=$KEEP/buildings/$(basename $d) && mkdir -p $dst && cp $d/trials.jsonl $d/summary.md $dst/
done
$PY $STUDY $KEEP/street_garage $KEEP/buildings --reference $V5/street_garage $V5/buildings \
  --plots --out $HERE/zero_shot_em_choice_long > $HERE/zero_shot_em_choice_long.log
$PY $STUDY $KEEP/street_garage $KEEP/buildings --reference $V5/street_garage $V5/buildings --reference-policy learned \
  --out $HERE/zero_shot_em_choice_long_vs_default > $HERE/zero_shot_em_choice_long_vs_default.log
rm -f $HERE/zero_shot_em_choice_long/buildings/*.png  # one trial per building: the street and garage plots are kept
