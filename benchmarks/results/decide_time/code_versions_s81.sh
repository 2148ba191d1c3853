# Sourced by benches_s81.sh (run from the repo root): session 80's final code (commit 946dedb3) checked out at
# BEFORE, and measure LOG ROOT SCRIPT ARGS... as in code_versions_s79.sh (the shared definition).
BEFORE=${BEFORE:-/tmp/before_s81}
[ -d $BEFORE/explore_rl ] || git worktree add $BEFORE 946dedb3
source $HERE/code_versions_s79.sh
