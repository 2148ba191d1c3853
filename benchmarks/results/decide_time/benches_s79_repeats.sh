#!/usr/bin/env bash
# Session 79: the same two benchmarks as benches_s79.sh run again, because two runs of today's bench_drive gave 2.52x
# and 2.08x (the machine's speed drifts between the two modes' replays): bench_drive at 45 deg twice more with each
# code (session 77's eee2a6d1 at BEFORE, and today's), interleaved, then bench_env once more with each, and bench_lidar with its interleaved wall-piece rounds. Logs
# bench_drive_45deg_{before_,}s79_r{2,3}.log, bench_env_{before_,}s79_r2.log, bench_lidar_rounds_s79.log.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
cd $HERE/../../..
source $HERE/code_versions_s79.sh
for r in 2 3; do
  measure bench_drive_45deg_s79_r$r.log $NOW bench_drive --fast-set slam=model_45deg
  measure bench_drive_45deg_before_s79_r$r.log $BEFORE bench_drive --fast-set slam=model_45deg
done
measure bench_env_before_s79_r2.log $BEFORE bench_env
measure bench_env_s79_r2.log $NOW bench_env
measure bench_lidar_rounds_s79.log $NOW bench_lidar
