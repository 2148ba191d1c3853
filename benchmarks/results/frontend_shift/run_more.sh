#!/usr/bin/env bash
# plan.md's addendum: the shipped actor and EM on buildings 1040-1099 under slam=model, then under slam=icp
# (keyframes_45deg/run.sh's config; resumable: finished buildings are skipped).
set -e
RUN=$(cd "$(dirname "$0")" && pwd)/../keyframes_45deg/run.sh
FIRST=1040 LAST=1099 SLAM=model OUT=/work/runs/model_val_more bash $RUN
FIRST=1040 LAST=1099 SLAM=icp OUT=/work/runs/icp_val_more bash $RUN
