#!/usr/bin/env bash
# plan.md: the default against EM with two trials per scene (seeds 0 and 1), and the default's seed 1 against
# its seed 0, from the runs kept in runs/ (folders of symlinks, one per kind and policy, in a tmp dir).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
PY=${PY:-/work/main/.venv/bin/python}
STUDY=$HERE/../../study_zero_shot.py
T=$(mktemp -d)
for policy in default em; do
  for kind in buildings sparse; do
    mkdir -p $T/${kind}_${policy}_2
    for f in $HERE/runs/${kind}_${policy}/*_building_*; do ln -s $f $T/${kind}_${policy}_2/seed0_$(basename $f); done
    for f in $HERE/runs/${kind}_${policy}_seed1/*_building_*; do ln -s $f $T/${kind}_${policy}_2/seed1_$(basename $f); done
  done
done
$PY $STUDY $T/buildings_default_2 $T/sparse_default_2 --reference $T/buildings_em_2 $T/sparse_em_2 \
  --pool val_whole_default_2trials --out $HERE/targets_default_2trials > $HERE/study_default_2trials.log
$PY $STUDY $HERE/runs/buildings_default_seed1 $HERE/runs/sparse_default_seed1 --reference $HERE/runs/buildings_default \
  $HERE/runs/sparse_default --reference-policy learned --pool default_seed1_vs_seed0 --out $HERE/noise_floor_default \
  > $HERE/noise_floor_default.log
rm -r $T
