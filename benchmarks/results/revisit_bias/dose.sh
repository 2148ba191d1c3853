#!/usr/bin/env bash
# plan.md addendum (exploratory): the shipped actor with revisit_bias=0.5 on validation buildings 1010-1039,
# val.sh's config, the prior only. Runs in /work/runs/rb_val/dose/building_SEED.
BIAS=${BIAS:-0.5} DOSE=1 exec "$(dirname "$0")/val.sh"
