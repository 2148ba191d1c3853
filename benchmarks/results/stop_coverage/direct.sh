#!/usr/bin/env bash
# plan.md (session 55): a learned-only variant's validation buildings (runs/SET, joined by study.sh) against the
# shipped default's trials of the same buildings (runs/val, runs/val2: the same config, graph.max_nodes=4096),
# paired by building (study_zero_shot.py --reference-policy learned): direct_SET.log, targets_SET_direct; a held-out
# set (SET ending in _test, session 58) against the default's trials of runs/test. REFS="dagger9k_val90" (session 59):
# against the trials of that folder instead (the session-58 default's validation runs). TAG=_vs_X (session 68): the
# report goes to direct_SET_vs_X.log / targets_SET_vs_X_direct, so a second reference keeps the first's log.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
SET=${1:?"give the set, e.g. bash direct.sh nodes512_val90"}
[ -d $HERE/runs/$SET ] || { echo "runs/$SET: not there; run SETS=$SET study.sh first" >&2; exit 2; }
[ -n "$REFS" ] || case $SET in *_test) REFS="test";; *) REFS="val val2";; esac  # held-out sets: runs/test's default
SPLIT=$(mktemp -d)
split_by_reference $SPLIT $HERE/runs/$SET $HERE/runs $REFS
$PY $RESULTS/../study_zero_shot.py $(for r in $REFS; do echo $SPLIT/$r; done) --reference $(for r in $REFS; do echo $HERE/runs/$r; done) \
  --reference-policy learned --pool ${SET}${TAG}_direct --out $HERE/targets_${SET}${TAG}_direct > $HERE/direct_$SET$TAG.log
rm -rf $SPLIT
