#!/usr/bin/env bash
# plan.md, session 61: the 200-building held-out pool (2020-2219) for the shipped actor with policy.loop_bias=0.04,
# one stage at a time (run.sh's config; each stage resumable: finished buildings are skipped):
#   prior_test   the prior on 2020-2119 (/work/runs/stop85_prior_dagger0.04_test; runs/test has EM's trials)
#   em_test2     EM on 2120-2219 (/work/runs/stop85_test2)
#   prior_test2  the prior on 2120-2219 (/work/runs/stop85_prior_dagger0.04_test2)
#   default_test2  session 62: the shipped default alone (runs/dagger9k_test's actor, no prior) on 2120-2219
#                  (/work/runs/stop85_dagger9k_test2; then SETS="dagger9k_test2 dagger9k_test200" study.sh)
#   bash heldout200_s61.sh prior_test em_test2 prior_test2
# then SETS="test2 prior_dagger0.04_test prior_dagger0.04_test2 prior_dagger0.04_test200" bash study.sh
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
stage_prior_test() {
  stop85 POLICIES=[learned] FIRST=2020 LAST=2119 OUT=/work/runs/stop85_prior_dagger0.04_test EXTRA="policy.loop_bias=0.04"
}
stage_em_test2() {
  stop85 POLICIES=[em] FIRST=2120 LAST=2219 OUT=/work/runs/stop85_test2
}
stage_prior_test2() {
  stop85 POLICIES=[learned] FIRST=2120 LAST=2219 OUT=/work/runs/stop85_prior_dagger0.04_test2 EXTRA="policy.loop_bias=0.04"
}
stage_default_test2() {
  stop85 POLICIES=[learned] FIRST=2120 LAST=2219 OUT=/work/runs/stop85_dagger9k_test2 \
    EXTRA="policy.checkpoint=$HERE/actors/s56_all9k.pt"
}
run_stages "prior_test em_test2 prior_test2 default_test2" "$@"
