"""Wall time per building of run.sh's streams (their 'building SEED start|end EPOCH' lines), per run folder's logs:
mean and total, and the ratio of two runs over the buildings both finished.

    python benchmarks/results/keyframes_45deg/wall_time.py LOGS_A... -- LOGS_B...
"""

from __future__ import annotations

import json
import re
import sys

import numpy as np

LINE = re.compile(r"building (\d+) (start|end) (\d+)")


def seconds_per_building(logs: list[str]) -> dict[int, float]:
    """Building seed -> seconds between its start and end lines (unfinished buildings left out)."""
    marks: dict[int, dict[str, int]] = {}
    for log in logs:
        with open(log) as handle:
            for line in handle:
                match = LINE.match(line.strip())
                if match:
                    marks.setdefault(int(match[1]), {})[match[2]] = int(match[3])
    return {seed: m["end"] - m["start"] for seed, m in marks.items() if {"start", "end"} <= m.keys()}


def main(argv: list[str]) -> dict:
    if "--" not in argv:
        sys.exit("usage: wall_time.py LOGS_A... -- LOGS_B... (run.sh's stream logs of two runs)")
    split = argv.index("--")
    a, b = seconds_per_building(argv[:split]), seconds_per_building(argv[split + 1:])
    both = sorted(a.keys() & b.keys())
    ratios = np.array([b[s] / a[s] for s in both])
    result = {"buildings": len(both), "mean_s_a": round(float(np.mean([a[s] for s in both])), 1),
              "mean_s_b": round(float(np.mean([b[s] for s in both])), 1),
              "total_ratio_b_over_a": round(sum(b[s] for s in both) / sum(a[s] for s in both), 3),
              "median_ratio_b_over_a": round(float(np.median(ratios)), 3) if len(both) else None}
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main(sys.argv[1:])
