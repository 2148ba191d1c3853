#!/usr/bin/env bash
# plan.md (session 39): issue 24's validation curve against wall-clock for the 2-hour pipeline: the 10-decision
# validation of session 38's kept snapshots (scratch_run/), stage 2's last.pt first (its baselines, played once
# here, become the cache of the later snapshots). Descriptive: nothing is selected from it. scratch_curve.py
# turns the log into scratch_curve.csv and .png.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/steps.sh
date; uptime
validate_10 $HERE/scratch_run/sparse/last.pt scratch_s38
for kind in office building lots sparse; do  # validate_10's cache location (_cached) for the later snapshots
  mkdir -p /work/runs/val/$kind/dagger_sparse_last
  [ -e /work/runs/val/$kind/dagger_sparse_last/episodes.jsonl ] || \
    cp /work/runs/val/$kind/scratch_s38/episodes.jsonl /work/runs/val/$kind/dagger_sparse_last/
done
for snapshot in office/last sparse/update_00240 office/update_00080 sparse/update_00080 sparse/update_00400 \
    sparse/update_00160 sparse/update_00320 sparse/update_00480 office/update_00160; do
  date; uptime
  validate_10 $HERE/scratch_run/$snapshot.pt scratch_s38_${snapshot/\//_}
done
date; uptime
echo "== done"
