#!/usr/bin/env bash
# plan.md, session 52 step A: the shipped actor with a weaker loop prior, learned policy alone, on the validation
# buildings at 85 % (run.sh's config), one B after the other: /work/runs/stop85_prior_B_val. BS="0.02 0.04": the Bs;
# FIRST/LAST/OUT_SUFFIX (default _val) pass through (the held-out step: FIRST=2020 LAST=2119 OUT_SUFFIX=_test).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
for B in ${BS:-0.02 0.04}; do
  POLICIES=[learned] EXTRA="policy.loop_bias=$B" OUT=/work/runs/stop85_prior_${B}${OUT_SUFFIX:-_val} bash $HERE/run.sh
done
