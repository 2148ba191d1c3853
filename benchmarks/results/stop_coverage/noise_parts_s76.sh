#!/usr/bin/env bash
# Session 76 (plan.md's addendum of 07:14 UTC; descriptive): noise_parts.py on the 90 validation buildings where EM
# ran twice (runs/val, runs/val2 and runs/em_replicate_val90), with eight validation variants and the named scenes'
# 50 EM trials (runs/street_garage50): noise_parts_s76.log.
# Session 77: arguments go on to noise_parts.py and LOG names the log, e.g. LOG=noise_parts_s77_two_trials.log bash
# noise_parts_s76.sh --test-trials 2 (the screen's chances with two trials per held-out building and policy); GARAGE
# and STREET: other trials of the scenes (files joined by +, e.g. EM's 200 of runs/street_garage50 and runs/named200_em).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
cd $HERE
variant() { echo "--variant $1=runs/$2"; }
$PY noise_parts.py --em-first runs/val runs/val2 --em-second runs/em_replicate_val90 \
  $(variant dagger9k dagger9k_val90) $(variant late150 prior_late150_val90) $(variant glots71 dagger71_val90) \
  $(variant lot74 dagger74_val90) $(variant revisit72 dagger72_val90) $(variant loop004 prior_dagger0.04_val90) \
  $(variant blind9k blind9k_val90) $(variant nodes512 nodes512_val90) \
  --scene garage=${GARAGE:-runs/street_garage50/1_garage/trials.jsonl} \
  --scene street=${STREET:-runs/street_garage50/0_street/trials.jsonl} \
  "$@" > ${LOG:-noise_parts_s76.log}
