#!/usr/bin/env bash
# Session 82: bench_collect (4 paired rounds each) of session 81's code (e37fb363) and today's (the learner's
# value targets without the duplicate critic calls; today's with the machine's ceiling, --ceiling), one after the
# other, nothing else running (issue 22 item 5). ROUND names the logs; round 1 runs today's code first, round 2
# session 81's first. The driver is session 81's.
ROUND=${ROUND:-1} SESSION=82 VERSIONS=code_versions_s82.sh NOW_ARGS=--ceiling \
  exec bash "$(dirname "$0")/collect_s81.sh"
