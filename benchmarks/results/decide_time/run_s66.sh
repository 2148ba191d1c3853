#!/usr/bin/env bash
# Session 66: the measurements after the exact speed-ups of the observation (windowed traversability and frontier
# clusters, frontier paths walked together) and of a decision's integer sorts (16-bit radix passes), one stage at a
# time on a quiet machine (uptime before and after each benchmark):
#   buildings  EM and the shipped default again on held-out buildings 2020-2029 with run.sh's config (slam=icp, 600 m,
#              4096 nodes, 85 %; /work/runs/decide_s66), then compare_s59.py against the stored trials (the same
#              trajectories?) and each policy's decision time on one machine, and study_zero_shot.py (per building)
#   benches    bench_decision_real, bench_sorting, bench_env, bench_explore (full size)
#   quick      every benchmark and study script that runs without a data folder, --quick (they import what
#              changed): rc, seconds and the JSON line (suite_time/quick_all_s66.log)
#   bash benchmarks/results/decide_time/run_s66.sh buildings benches quick
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
cd $HERE/../../..
source $HERE/../keep.sh
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
STORED="em=benchmarks/results/stop_coverage/runs/test learned=benchmarks/results/stop_coverage/runs/dagger9k_test"
stage_buildings() {
  FIRST=2020 LAST=2029 OUT=/work/runs/decide_s66 bash $HERE/buildings_s59.sh
  $PY $HERE/compare_s59.py /work/runs/decide_s66 --stored $STORED > $HERE/compare_s66.log
  $PY benchmarks/study_zero_shot.py /work/runs/decide_s66 --pool decide_s66 --out $HERE/targets > $HERE/study_s66.log
}
stage_benches() {
  for name in bench_decision_real bench_sorting bench_env bench_explore; do
    { echo "uptime at start: $(uptime)"; $PY benchmarks/$name.py; echo "uptime at end: $(uptime)"; } \
      > $HERE/${name}_s66.log 2>&1
  done
}
QUICK="bench_building bench_collect bench_decision bench_decision_real bench_drive bench_env bench_explore bench_frontends
  bench_import bench_lidar bench_policy bench_slam bench_sorting study_buildings study_fidelity study_inflation
  study_keyframes study_ordering study_safety sweep_alpha bench_kernels bench_update"  # session 60's list (the rest
  # need data folders) + bench_sorting (session 66) + bench_kernels (session 81) + bench_update (session 82)
stage_quick() {
  out=${QUICK_LOG:-$HERE/../suite_time/quick_all_s66.log}  # QUICK_LOG: another session's log
  : > $out
  for name in $QUICK; do
    start=$(date +%s)
    set +e
    $PY benchmarks/$name.py --quick > /tmp/quick_$name.out 2>&1
    rc=$?
    set -e
    echo "$name rc=$rc $(( $(date +%s) - start ))s $(grep '^{' /tmp/quick_$name.out | tail -1)" >> $out
  done
}
run_stages "buildings benches quick" "$@"
