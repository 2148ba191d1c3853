#!/usr/bin/env bash
# plan.md step 3 (only for a candidate that passed step 2; run once): the candidate alone on the held-out buildings
# 2020-2119 (zero_shot_buildings_100/run.sh's config: slam=icp, 250 m, one trial, two streams of one in-process
# worker), kept in runs/heldout_TAG and paired by building with that folder's EM and shipped-actor trials.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
ACTOR=${ACTOR:-/work/runs/tmb/checkpoints/last.pt}
OUT=/work/runs/tmb_heldout$TAG
EVAL="nice -n 5 /work/main/.venv/bin/explore-rl-eval"
COMMON="scene=building slam=icp graph.max_nodes=1024 evaluate.trials=1 explore.travel_budget=250 \
  evaluate.policies=[learned] policy.checkpoint=$ACTOR evaluate.progress_bar=false evaluate.workers=1"
$EVAL -m $COMMON scene.seed=$(seq -s, 2020 2 2118) out=$OUT/even > ${OUT}_even.log 2>&1 &
$EVAL -m $COMMON scene.seed=$(seq -s, 2021 2 2119) out=$OUT/odd > ${OUT}_odd.log 2>&1 &
wait
B100=$RESULTS/zero_shot_buildings_100/runs
N=heldout$TAG
for s in even odd; do keep $OUT/$s $HERE/runs/$N/$s; done
$PY $RESULTS/../study_zero_shot.py $HERE/runs/$N/even $HERE/runs/$N/odd --reference $B100/even $B100/odd \
  --pool $N --out $HERE/targets_$N > $HERE/study_$N.log
$PY $RESULTS/../study_zero_shot.py $HERE/runs/$N/even $HERE/runs/$N/odd --reference $B100/even $B100/odd \
  --reference-policy learned --pool ${N}_direct --out $HERE/targets_${N}_direct > $HERE/direct_$N.log
