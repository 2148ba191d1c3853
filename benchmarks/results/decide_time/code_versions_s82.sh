# Sourced by collect_s82.sh (run from the repo root): session 81's final code (commit e37fb363) checked out at
# BEFORE, and measure LOG ROOT SCRIPT ARGS... as in code_versions_s79.sh (the shared definition).
BEFORE=${BEFORE:-/tmp/before_s82}
[ -d $BEFORE/explore_rl ] || git worktree add $BEFORE e37fb363
source $HERE/code_versions_s79.sh
