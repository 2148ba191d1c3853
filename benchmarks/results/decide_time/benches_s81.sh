#!/usr/bin/env bash
# Session 81: EM's landmark fusion, its round layout and the line of sight compiled (explore_rl/planning/compiled.py,
# explore_rl/mapping/compiled.py), the voxel box grown geometrically. Issue 22's items 3 and 4 (bench_drive, bench_env)
# and issue 24's decision time (bench_decision_real: EM and the learned policy both fuse landmarks) on this machine,
# quiet, one benchmark at a time, each with its own baseline in the same run, and session 80's code (946dedb3)
# interleaved with today's (the machine's speed drifts between runs). STAGE=env|decide|drive picks the benchmark
# (several: STAGE="env decide"); ROUND names the logs.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
cd $HERE/../../..
source $HERE/code_versions_s81.sh
R=${ROUND:-1}
for stage in ${STAGE:-env}; do
  case $stage in
    env)
      measure bench_env_s81_r$R.log $NOW bench_env
      measure bench_env_before_s81_r$R.log $BEFORE bench_env ;;
    decide)
      measure bench_decision_real_before_s81_r$R.log $BEFORE bench_decision_real
      measure bench_decision_real_s81_r$R.log $NOW bench_decision_real ;;
    drive)
      measure bench_drive_45deg_s81_r$R.log $NOW bench_drive --fast-set slam=model_45deg
      measure bench_drive_45deg_before_s81_r$R.log $BEFORE bench_drive --fast-set slam=model_45deg ;;
  esac
done
