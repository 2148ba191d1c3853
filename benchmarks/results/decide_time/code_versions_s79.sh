# Sourced by benches_s79.sh and benches_s79_repeats.sh (run from the repo root): session 77's code (commit eee2a6d1)
# checked out at BEFORE, and measure LOG ROOT SCRIPT ARGS..., which runs ROOT's benchmarks/SCRIPT.py with ROOT's
# explore_rl first on PYTHONPATH into HERE/LOG, uptime and commit before, uptime after.
source $HERE/../keep.sh
BEFORE=${BEFORE:-/tmp/before_s79}
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
[ -d $BEFORE/explore_rl ] || git worktree add $BEFORE eee2a6d1
measure() {
  { echo "uptime at start: $(uptime)"; echo "code: $(git -C $2 rev-parse HEAD)";
    PYTHONPATH=$2 $PY $2/benchmarks/$3.py "${@:4}"; echo "uptime at end: $(uptime)"; } > $HERE/$1 2>&1
}
NOW=$(pwd)
