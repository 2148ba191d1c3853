#!/usr/bin/env bash
# Session 59: EM and the shipped default again on held-out buildings 2020-2023 with run.sh's config (slam=icp, 600 m,
# graph.max_nodes=4096, 85 % explored), two streams, one BLAS/torch thread per process. Two questions: do the session's
# changes (ms_decide, windowed Dijkstra, map error at once) leave every trajectory as it was (the same travel, decisions
# and map error as the stored trials of runs/test and runs/dagger9k_test), and what is each policy's decision time on
# the same machine and code (compare_s59.py). Output /work/runs/decide_s59/building_SEED.
cd "$(dirname "$0")/../../.."
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
POLICIES=[learned,em] SLAM=icp BUDGET=600 MAX_NODES=4096 FIRST=${FIRST:-2020} LAST=${LAST:-2023} \
  OUT=${OUT:-/work/runs/decide_s59} bash benchmarks/results/keyframes_45deg/run.sh
