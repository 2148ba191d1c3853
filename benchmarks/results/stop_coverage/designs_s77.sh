#!/usr/bin/env bash
# Session 77 (plan.md, step 2; arithmetic only, selects nothing): the chance that a candidate of a given true ratio
# passes the screen, the held-out pool and both named scenes under several test designs, from noise_parts.py's
# one-trial noise of session 76 (noise_parts_s76.sh's inputs) and the scenes' map-error spread over every EM trial kept
# there (seeds 0-49 of runs/street_garage50 and those of runs/named200_em; each log's scene lines give how many).
# One log per design: designs_s77_NAME.log; the summary
# designs_s77.log (per design, per true ratio: the map error's chance over every part, and travel's over screen and
# pool).
#   now         session 76's sizes: 1 trial per validation and held-out building, 120 trials per scene against 200
#   two         2 trials per validation and held-out building and policy, 200 per scene against 200
#   two300      2 trials per validation and held-out building and policy, 300 per scene against 300
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
source $HERE/../keep.sh
cd $HERE
export GARAGE=runs/street_garage50/1_garage/trials.jsonl+runs/named200_em/1_garage/trials.jsonl
export STREET=runs/street_garage50/0_street/trials.jsonl+runs/named200_em/0_street/trials.jsonl
design() {
  LOG=designs_s77_$1.log bash noise_parts_s76.sh "${@:2}"
  tail -1 designs_s77_$1.log | $PY -c "
import json, sys
t = json.load(sys.stdin)['screen']
for r, p in t['map_error_every_part'].items():
    print(json.dumps({'design': '$1', 'true_ratio': float(r), 'map_error_every_part': p,
                      'travel_screen_and_pool': t['travel'][r]['both']}))"
}
{ design now
  design two --validation-trials 2 --test-trials 2 --scene-trials 200
  design two300 --validation-trials 2 --test-trials 2 --scene-trials 300 --scene-reference 300
} > designs_s77.log
