# Sourced by benches_s80.sh (run from the repo root): session 79's final code (commit c20491df) checked out at
# BEFORE, and measure LOG ROOT SCRIPT ARGS... as in code_versions_s79.sh (the shared definition).
BEFORE=${BEFORE:-/tmp/before_s80}
[ -d $BEFORE/explore_rl ] || git worktree add $BEFORE c20491df
source $HERE/code_versions_s79.sh
