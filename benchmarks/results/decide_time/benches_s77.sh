#!/usr/bin/env bash
# Session 77: issue 22's items 3 and 4 measured again on this machine, quiet, one benchmark at a time (uptime before
# and after each): bench_env.py (full size: long office episodes, fast against reference backends, item 4) and
# bench_drive.py at session 50's 45-degree keyframes (the drive against its reference replays, item 3). Logs
# bench_env_s77.log, bench_drive_45deg_s77.log.
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
cd $HERE/../../..
source $HERE/../keep.sh
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
measure() {  # measure LOG SCRIPT ARGS...
  { echo "uptime at start: $(uptime)"; $PY benchmarks/$2.py "${@:3}"; echo "uptime at end: $(uptime)"; } > $HERE/$1 2>&1
}
measure bench_env_s77.log bench_env
measure bench_drive_45deg_s77.log bench_drive --fast-set slam=model_45deg
