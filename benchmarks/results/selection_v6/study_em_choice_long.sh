#!/usr/bin/env bash
# plan.md (session 35): keep em_choice_long's whole explorations (trials and summaries) in runs/, then pool
# its two trials per scene against EM's two trials (the rule's figure) and against the default's two trials.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
PY=${PY:-/work/main/.venv/bin/python}
STUDY=$HERE/../../study_zero_shot.py
for kind in buildings sparse; do
  for seed in 0 1; do
    src=/work/runs/val_whole/${kind}_em_choice_long_seed$seed dst=$HERE/runs/${kind}_em_choice_long_seed$seed
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
  link ${kind}_cand $HERE/runs/${kind}_em_choice_long_seed0 $HERE/runs/${kind}_em_choice_long_seed1
  link ${kind}_em $HERE/runs/${kind}_em $HERE/runs/${kind}_em_seed1
  link ${kind}_default $HERE/runs/${kind}_default $HERE/runs/${kind}_default_seed1
done
$PY $STUDY $T/buildings_cand $T/sparse_cand --reference $T/buildings_em $T/sparse_em \
  --pool val_whole_em_choice_long_2trials --out $HERE/targets_em_choice_long_2trials > $HERE/study_em_choice_long_2trials.log
$PY $STUDY $T/buildings_cand $T/sparse_cand --reference $T/buildings_default $T/sparse_default --reference-policy learned \
  --pool em_choice_long_vs_default_2trials --out $HERE/direct_em_choice_long_vs_default > $HERE/direct_em_choice_long_vs_default.log
rm -r $T
