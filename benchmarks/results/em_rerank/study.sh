#!/usr/bin/env bash
# plan.md step 2 (a diagnostic after the addendum): run.sh's K = 2 validation trials kept in runs/val_top2 and
# studied against EM's and the shipped actor's trials of the same config (study_val_top2.log, direct_val_top2.log).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
val_study /work/runs/em_top_2_val $HERE val_top2
