#!/usr/bin/env bash
# plan.md, session 65: the next fresh held-out pool 2420-2619 (200 buildings, run.sh's stop-85 config), reserved for the
# next candidate chosen on validation (1010-1099); resumable (finished buildings are skipped):
#   em_test4   EM's trials (/work/runs/stop85_test4; policy-independent groundwork, started before any candidate exists)
#   bash fresh_pool_s65.sh em_test4
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
RUN="bash $HERE/../keyframes_45deg/run.sh"
POOL="SLAM=icp BUDGET=600 MAX_NODES=4096 FIRST=2420 LAST=2619"
source $HERE/../keep.sh
stage_em_test4() { env $POOL POLICIES=[em] OUT=/work/runs/stop85_test4 $RUN; }
run_stages "em_test4" "$@"
