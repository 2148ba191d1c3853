#!/usr/bin/env bash
# plan.md, session 63: the fresh held-out pool 2220-2419 (200 buildings, run.sh's config), one stage at a time
# (each resumable: finished buildings are skipped):
#   em_test3       EM's trials (/work/runs/stop85_test3; policy-independent groundwork)
#   default_test3  the shipped default's replication (actors/s56_all9k.pt, no prior; /work/runs/stop85_dagger9k_test3),
#                  after em_test3 is complete
#   em_test4       session 65: EM's trials on the next fresh pool 2420-2619 (/work/runs/stop85_test4), reserved for the
#                  next candidate chosen on validation (policy-independent groundwork)
#   late150_test4  session 68: the validation choice (the shipped actor, policy.loop_bias=0.04 from 150 m of travel) on
#                  2420-2619 (/work/runs/stop85_prior_late150_test4), after em_test4 is complete
#   default_test4  session 69: the shipped default (no prior) on 2420-2619 (/work/runs/stop85_dagger9k_test4), paired
#                  with late150_test4 by building (descriptive: what the prior changes held out)
#   em_test5       session 71: EM's trials on the next fresh pool 2620-2819 (/work/runs/stop85_test5), reserved for the
#                  next candidate chosen on validation (policy-independent groundwork)
#   late150_test5  session 72: the late-prior option's replication on 2620-2819 (/work/runs/stop85_prior_late150_test5;
#                  the shipped actor, pinned as actors/s56_all9k.pt, its weights), after em_test5 is complete
#   dagger73_test5  session 72: the validation choice, the lot-only revisit weight (actors/s72_lotrevisit3.pt), on
#                  2620-2819 (/work/runs/stop85_dagger73_test5; plan.md session 72 step 8), after em_test5 is complete
#   em_test6       session 74: EM's trials on the next fresh pool 2820-3019 (/work/runs/stop85_test6), reserved for the
#                  next candidate chosen on validation (policy-independent groundwork)
#   dagger74_test6  session 74: session 74's DAgger round of the lot-only arm (actors/s74_dagger_lot.pt), if chosen on
#                  validation (plan.md session 74 step 4), on 2820-3019 (/work/runs/stop85_dagger74_test6), after
#                  em_test6 is complete
#   bash fresh_pool_s63.sh em_test3 default_test3
# then SETS="test3 dagger9k_test3" bash study.sh (study_dagger9k_test3.log: the replication, read by plan.md's rule)
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
POOL="FIRST=2220 LAST=2419"
NEXT_POOL="FIRST=2420 LAST=2619"  # session 65: reserved for the next candidate
POOL5="FIRST=2620 LAST=2819"  # session 71: the pool after it
POOL6="FIRST=2820 LAST=3019"  # session 74: the pool after that
source $HERE/../keep.sh
stage_em_test3() { stop85 $POOL POLICIES=[em] OUT=/work/runs/stop85_test3; }
stage_default_test3() {
  stop85 $POOL POLICIES=[learned] OUT=/work/runs/stop85_dagger9k_test3 EXTRA="policy.checkpoint=$HERE/actors/s56_all9k.pt"
}
stage_em_test4() { stop85 $NEXT_POOL POLICIES=[em] OUT=/work/runs/stop85_test4; }
stage_late150_test4() {
  stop85 $NEXT_POOL POLICIES=[learned] OUT=/work/runs/stop85_prior_late150_test4 \
    EXTRA="policy.loop_bias=0.04 policy.loop_bias_from_m=150"
}
stage_default_test4() {
  stop85 $NEXT_POOL POLICIES=[learned] OUT=/work/runs/stop85_dagger9k_test4 EXTRA="policy.checkpoint=$HERE/actors/s56_all9k.pt"
}
stage_em_test5() { stop85 $POOL5 POLICIES=[em] OUT=/work/runs/stop85_test5; }
stage_late150_test5() {
  stop85 $POOL5 POLICIES=[learned] OUT=/work/runs/stop85_prior_late150_test5 \
    EXTRA="policy.checkpoint=$HERE/actors/s56_all9k.pt policy.loop_bias=0.04 policy.loop_bias_from_m=150"
}
stage_dagger73_test5() {
  stop85 $POOL5 POLICIES=[learned] OUT=/work/runs/stop85_dagger73_test5 EXTRA="policy.checkpoint=$HERE/actors/s72_lotrevisit3.pt"
}
stage_em_test6() { stop85 $POOL6 POLICIES=[em] OUT=/work/runs/stop85_test6; }
stage_dagger74_test6() {
  stop85 $POOL6 POLICIES=[learned] OUT=/work/runs/stop85_dagger74_test6 EXTRA="policy.checkpoint=$HERE/actors/s74_dagger_lot.pt"
}
run_stages "em_test3 default_test3 em_test4 late150_test4 default_test4 em_test5 late150_test5 dagger73_test5 em_test6 \
dagger74_test6" "$@"
