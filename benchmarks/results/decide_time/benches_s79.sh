#!/usr/bin/env bash
# Session 79: the robot's side of driving made cheaper (scalar SE(2) helpers, one distance query per motion step,
# the safety ring casting hit points only). Issue 22's items 3 and 4 measured on this machine, quiet, one benchmark
# at a time (uptime before and after each), each benchmark's own baseline in the same run; and, as a before/after
# figure across commits, the same benchmarks with session 77's code (commit eee2a6d1, checked out at BEFORE and put
# first on PYTHONPATH), interleaved with today's. Logs: bench_{drive_45deg,env}_{before_,}s79.log, bench_lidar_s79.log.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
cd $HERE/../../..
source $HERE/code_versions_s79.sh
measure bench_drive_45deg_before_s79.log $BEFORE bench_drive --fast-set slam=model_45deg
measure bench_drive_45deg_s79.log $NOW bench_drive --fast-set slam=model_45deg
measure bench_env_s79.log $NOW bench_env
measure bench_env_before_s79.log $BEFORE bench_env
measure bench_lidar_s79.log $NOW bench_lidar
# Added after the five above had run, and run on its own (this line with the set-up above): the drive again with
# the session's code and its cProfile bound (the shared native calls alone).
measure bench_drive_45deg_profile_s79.log $NOW bench_drive --fast-set slam=model_45deg --profile $HERE/bench_drive_45deg_profile_s79.txt
