#!/usr/bin/env bash
# plan.md: the run's actor on the validation buildings (../stakes_distill/run.sh, NAME=a2c_me) kept in runs/val and
# studied against EM's and the shipped actor's trials of the same config (study_val.log, direct_val.log).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
val_study /work/runs/a2c_me_val $HERE val
