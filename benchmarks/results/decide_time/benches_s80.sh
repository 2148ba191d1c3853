#!/usr/bin/env bash
# Session 80: the map updates' loops compiled (explore_rl/mapping/compiled.py: beam tracing, the ray-grid
# collapse, the log-odds steps, the voxel keys). Issue 22's items 3 and 4 on this machine, quiet, one benchmark at
# a time, each with its own baseline in the same run, and session 79's code (c20491df) interleaved with today's
# (the machine's speed drifts between runs). STAGE=drive|env picks the benchmark; ROUND names the logs.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
cd $HERE/../../..
source $HERE/code_versions_s80.sh
R=${ROUND:-1}
case ${STAGE:-drive} in
  drive)
    measure bench_drive_45deg_before_s80_r$R.log $BEFORE bench_drive --fast-set slam=model_45deg
    measure bench_drive_45deg_s80_r$R.log $NOW bench_drive --fast-set slam=model_45deg ;;
  env)
    measure bench_env_s80_r$R.log $NOW bench_env
    measure bench_env_before_s80_r$R.log $BEFORE bench_env ;;
esac
