#!/usr/bin/env bash
# plan.md addendum: the online DAgger actor's validation trials (../stakes_distill/run.sh, NAME=lf_dagger) kept in
# runs/val_dagger and studied against EM's and the shipped actor's trials of the same config (study_val_dagger.log,
# direct_val_dagger.log).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
val_study /work/runs/lf_dagger_val $HERE val_dagger
