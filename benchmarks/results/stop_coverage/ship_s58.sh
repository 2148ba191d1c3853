#!/usr/bin/env bash
# plan.md, session 58 step 2: the report of the new default (actors/s56_all9k.pt, shipped as
# policies/buildings_dagger_em_choice), after street_garage.sh's run of it; in order, one job on the machine at a time:
#   heldout   the held-out buildings 2103-2119 session 57's cut left (run.sh's config, /work/runs/stop85_dagger9k_test)
#   protocol  the 10-decision protocol on held-out office 2000-2001 x 9 starts and buildings 2000-2004 x 4 starts,
#             against the previous default on the same episodes (--compare): protocol_s58_{office,building}.log
#   baselines nearest frontier and random on 10 held-out buildings 2020-2029 (run.sh's config; issue 24 item 5's four
#             policies there, with the runs/test trials of EM and both learned policies): /work/runs/stop85_baselines_test
#   bash ship_s58.sh heldout protocol baselines
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
cd $HERE/../../..  # the repository
ACTOR=policies/buildings_dagger_em_choice/actor.pt  # actors/s56_all9k.pt's weights, its training layouts in meta
PREVIOUS=policies/buildings_sparse_em_choice/actor.pt
RUN="bash benchmarks/results/keyframes_45deg/run.sh"
for stage in "$@"; do
  echo "$stage start $(date -u +%H:%M:%S)"
  case $stage in
    heldout)
      POLICIES=[learned] SLAM=icp BUDGET=600 MAX_NODES=4096 FIRST=2103 LAST=2119 OUT=/work/runs/stop85_dagger9k_test \
        EXTRA="policy.checkpoint=$HERE/actors/s56_all9k.pt" $RUN;;
    protocol)
      PROTOCOL="nice -n 5 .venv/bin/python benchmarks/study_learning.py --policy $ACTOR --compare $PREVIOUS \
        --max-decisions 10 --workers 2 --set graph.features=extended"
      $PROTOCOL --layouts 2000 2001 --starts 9 --out /work/runs/protocol_s58/office > $HERE/protocol_s58_office.log
      $PROTOCOL --scene building --layouts 2000 2001 2002 2003 2004 --starts 4 --out /work/runs/protocol_s58/building \
        > $HERE/protocol_s58_building.log;;
    baselines)
      POLICIES=[nearest,random] SLAM=icp BUDGET=600 MAX_NODES=4096 FIRST=2020 LAST=2029 \
        OUT=/work/runs/stop85_baselines_test $RUN;;
    *) echo "stage $stage: give heldout, protocol or baselines" >&2; exit 2;;
  esac
  echo "$stage end $(date -u +%H:%M:%S)"
done
