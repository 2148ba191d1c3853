#!/usr/bin/env bash
# Session 75: every variant measured on the 90 validation buildings 1010-1099 at 85 % explored on one travel /
# map-error figure (line.py; the line through session 52's default and its loop-0.08 candidate, as in session 54):
# session 68's points, the DAgger actors of sessions 71, 72 and 74 and EM against itself (noise_floor_s75.sh)
# (each study_zero_shot.py's targets.json here).
# Writes line.png, line.csv and line.log in this folder.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
cd $HERE
point() { echo "--point $1=targets_$2/$2/targets.json"; }
$PY line.py --out . $(point default val90) $(point loop0.08_candidate prior_cand0.08_val90) \
  $(point loop0.08_until150m prior_open150_val90) $(point loop0.08_until250m prior_open250_val90) \
  $(point closure8.2 prior_closure_val90) $(point nodes512 nodes512_val90) $(point dagger9k dagger9k_val90) \
  $(point blind9k blind9k_val90) $(point dagger9k_loop0.04 prior_dagger0.04_val90) \
  $(point dagger9k_loop0.02 prior_dagger0.02_val90) $(point dagger9k_loop0.04_from150m prior_late150_val90) \
  $(point dagger71_glots dagger71_val90) $(point dagger72_revisit3 dagger72_val90) $(point dagger74_lot dagger74_val90) \
  $(point em_replicate em_replicate_val90) \
  --line default loop0.08_candidate > line.log
